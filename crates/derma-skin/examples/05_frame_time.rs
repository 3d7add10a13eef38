//! Frame time of the renderer: the built-in head with a generated texture set (subsurface blur,
//! eyes with refracting corneas, the key light's shadow map), rendered frame after frame into
//! the same targets without read-back, as an interactive viewer would.
//!
//! cargo run --release -p derma-skin --example 05_frame_time -- [SIZES] [FRAMES]
//! SIZES: comma-separated WxH or N (default 256); FRAMES per size (default 3). bench/render.sh
//! runs it at 1024² and 1920×1080.

use derma_render::{Renderer, Scene, Setup, View};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let sizes = args.first().map(String::as_str).unwrap_or("256");
    let frames: usize = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(3);
    let mut g = derma_skin::SkinGenerator::new(derma_skin::SkinConfig::default());
    g.config_mut().size = 1024;
    let set = g.run()?;
    let maps = set.render.skin_maps(false);
    let scene = Scene::head(derma_head::Head::builtin(), maps, &[], None, (0.0, 0.0));
    let triangles: usize = scene.parts.iter().map(|p| p.vertices.len() / 3).sum();
    let r = Renderer::new(&scene)?;
    println!("adapter: {}; {triangles} triangles", r.adapter);
    for s in sizes.split(',') {
        let (a, b) = s.split_once('x').unwrap_or((s, s));
        let (w, h): (u32, u32) = (a.trim().parse()?, b.trim().parse()?);
        let t = r.time_frames(&View::default(), &Setup::Studio.lighting(), w, h, frames)?;
        println!("{w}x{h}: {:.3} ms per frame ({frames} frames)", 1e3 * t);
    }
    Ok(())
}
