//! The built-in head neutral and posed by face units (a half smile with the jaw a little open),
//! side by side, drawn by derma-render's CPU renderer with a uniform skin material: the figure
//! of docs/head.md.
//! Run: `cargo run --release -p derma-render --example 01_posed_head [OUT_DIR]` (default: a
//! `derma-render` folder in the temporary directory).

use derma_render::cpu::{head_props, render_with, uniform_color, FlatMaterial};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Default: a directory in the system's temporary folder (never the working tree).
    let out = std::env::args().nth(1).map_or_else(
        || std::env::temp_dir().join("derma-render"),
        std::path::PathBuf::from,
    );
    std::fs::create_dir_all(&out)?;
    let head = derma_head::Head::builtin();
    let posed = head.posed_skin(&[
        ("mouthSmileLeft", 0.6),
        ("mouthSmileRight", 0.6),
        ("jawOpen", 0.3),
    ]);
    let base = uniform_color([0.45, 0.33, 0.28]);
    let material = FlatMaterial::new(0.5, 0.35);
    let tex = material.textures(&base);
    let props = head_props(head);
    let views: Vec<[derma_core::Map; 3]> = [&head.skin, &posed]
        .iter()
        .map(|m| {
            let t = derma_core::mesh::mikktspace_tangents(m);
            render_with(m, &t, &tex, &props, 0.35, 512)
        })
        .collect();
    let sheet = derma_render::sheet::compose(&views, &[], 512);
    let path = out.join("smile.png");
    derma_core::image_io::write_png8(&path, &[&sheet[0], &sheet[1], &sheet[2]])?;
    println!("wrote {}", path.display());
    Ok(())
}
