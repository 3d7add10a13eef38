//! The built-in head as data: prints its parts, landmarks and face units, poses it with two face
//! units and writes it as OBJ and GLB (with the 52 face units as morph targets).
//! Run: `cargo run --release -p derma-head --example 01_head_export [OUT_DIR]` (default: a
//! `derma-head` folder in the temporary directory).

use derma_head::{export, Head, REGIONS};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Default: a directory in the system's temporary folder (never the working tree).
    let out = std::env::args().nth(1).map_or_else(
        || std::env::temp_dir().join("derma-head"),
        std::path::PathBuf::from,
    );
    std::fs::create_dir_all(&out)?;
    let head = Head::builtin();
    let (lo, hi) = head.skin.bounds();
    println!(
        "skin: {} vertices, {} triangles, {:.0} cm², bounds {:.0} × {:.0} × {:.0} mm",
        head.skin.positions.len(),
        head.skin.triangles.len(),
        head.skin.area() / 100.0,
        hi.x - lo.x,
        hi.y - lo.y,
        hi.z - lo.z
    );
    for p in &head.parts {
        println!(
            "{}: {} vertices, {} triangles",
            p.name,
            p.mesh.positions.len(),
            p.mesh.triangles.len()
        );
    }
    for (name, p) in &head.landmarks.points {
        println!("landmark {name}: ({:.1}, {:.1}, {:.1}) mm", p.x, p.y, p.z);
    }
    println!("regions: {}", REGIONS.join(", "));
    let units = head.face_units();
    println!(
        "{} face units: {}",
        units.len(),
        units
            .iter()
            .map(|u| u.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    );
    // A half smile with the jaw a little open: the posed skin as OBJ.
    let posed = head.posed_skin(&[
        ("mouthSmileLeft", 0.6),
        ("mouthSmileRight", 0.6),
        ("jawOpen", 0.3),
    ]);
    posed.write_obj(&out.join("smile.obj"))?;
    export::write_obj(head, &out.join("head.obj"), &out.join("head_parts.obj"))?;
    export::write_glb(head, &out.join("head.glb"))?;
    println!(
        "wrote {}/head.obj, head_parts.obj, head.glb, smile.obj",
        out.display()
    );
    Ok(())
}
