//! Table 4.1 of the thesis on the built-in head: every sampler and the exact baselines at
//! 1920 × 1080 (or the size given), with time, texture accesses per relevant texel and error
//! against the exact transform.
//!
//! cargo run --release -p derma-eyes --example 02_distance_fields [WIDTH HEIGHT]

use derma_eyes::sdf;

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (w, h) = (
        args.first().copied().unwrap_or(1920),
        args.get(1).copied().unwrap_or(1080),
    );
    let head = derma_head::Head::builtin();
    let scene = sdf::scene::head_close_up(head, w, h);
    let range = sdf::table::RANGE_MM;
    let rows = sdf::table::measure(&scene.g, range, 3);
    println!("{}", sdf::table::markdown(&rows, w, h));
}
