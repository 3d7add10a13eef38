use derma_photo::unwrap::*;
fn main() {
    let head = derma_head::Head::builtin();
    let disc = derma_photo::synthetic::face_disc(head).unwrap();
    for view in [None, Some(glam::Vec3::NEG_Z)] {
        for tol in [1e-4, 1e-5, 1e-7] {
            let t0 = std::time::Instant::now();
            let u = unwrap(
                &disc,
                &UnwrapOptions {
                    view,
                    tolerance: tol,
                    iterations: 1000,
                    ..Default::default()
                },
            )
            .unwrap();
            println!(
                "{view:?} tol {tol}: {:?} tutte {:?} it {} {:.2}s",
                u.stretch,
                u.tutte_stretch.l2,
                u.iterations,
                t0.elapsed().as_secs_f64()
            );
        }
    }
}
