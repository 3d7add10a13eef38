//! Renders the built-in head with a texture set from `derma skin` under both lighting setups.
//!
//! cargo run --release -p derma-skin --example 04_render_head -- [SKIN_DIR] [OUT_DIR]
//! (default: generates a 1024² set in a temporary directory and writes the renders there)

use derma_render::{Renderer, Scene, Setup, SkinMaps, View};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args
        .get(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("derma-render-example"));
    std::fs::create_dir_all(&out)?;
    let skin_dir = match args.first() {
        Some(d) => PathBuf::from(d),
        None => {
            let dir = out.join("skin");
            let mut g = derma_skin::SkinGenerator::new(derma_skin::SkinConfig::default());
            g.config_mut().size = 1024;
            g.run()?.write(&dir, &derma_core::progress::Silent)?;
            dir
        }
    };
    let maps = SkinMaps::from_dir(&skin_dir)?;
    let scene = Scene::head(derma_head::Head::builtin(), maps, &[], None, (0.0, 0.0));
    let r = Renderer::new(&scene)?;
    for setup in Setup::ALL {
        for (name, yaw) in [("front", 0.0), ("three-quarter", 35.0)] {
            let img = r.render(
                &View {
                    yaw_deg: yaw,
                    ..Default::default()
                },
                &setup.lighting(),
                768,
                768,
            )?;
            let m = img.display_maps();
            let path = out.join(format!("{}-{name}.png", setup.name()));
            derma_core::image_io::write_png8(&path, &[&m[0], &m[1], &m[2]])?;
            println!("{}", path.display());
        }
    }
    Ok(())
}
