use derma_optics::run::{run_cpu, Run};
use derma_optics::slab::{parse_layer, slab_stack, SlabResult};

#[test]
fn quick() {
    for (layers, na, nb, r, tt) in [
        (vec!["0.2,10,90,0.75,1"], 1.0, 1.0, 0.09739, 0.66096),
        (vec!["1,1,100,0.9,1.4"], 1.0, 1.0, 0.2605, 0.4613),
        (vec!["0.1,10,400,0.85,1.4", "1,1,200,0.8,1.4"], 1.0, 1.0, 0.3294, 0.1491),
    ] {
        let ls = layers.iter().map(|l| parse_layer(l).unwrap()).collect();
        let run = Run::totals(slab_stack(ls, na, nb), 200_000, 1);
        let t0 = std::time::Instant::now();
        let t = run_cpu(&run, &|_| {}).unwrap();
        let s = SlabResult::from_tally(&t, t0.elapsed().as_secs_f64(), "cpu");
        println!("{layers:?} R={:.5} (rs {:.5}) T={:.5} A={:.5} ±{:.5} ±{:.5} ref R {r} T {tt}  {:.0} ph/s book {:e}", s.r_specular + s.r_diffuse, s.r_specular, s.t_total, s.absorbed, s.stderr.r_diffuse, s.stderr.t_total, s.photons_per_s, s.bookkeeping_error);
    }
}

#[test]
fn quick_gpu() {
    println!("gpu: {:?}", derma_optics::gpu::available());
    for (layers, na, nb, r, tt) in [
        (vec!["0.2,10,90,0.75,1"], 1.0, 1.0, 0.09739, 0.66096),
        (vec!["1,1,100,0.9,1.4"], 1.0, 1.0, 0.2605, 0.4613),
    ] {
        let ls = layers.iter().map(|l| parse_layer(l).unwrap()).collect();
        let run = Run::totals(slab_stack(ls, na, nb), 200_000, 1);
        let t0 = std::time::Instant::now();
        let t = derma_optics::gpu::run_gpu(&run, &|_| {}).unwrap();
        let s = SlabResult::from_tally(&t, t0.elapsed().as_secs_f64(), "gpu");
        println!("{layers:?} R={:.5} (rs {:.5}) T={:.5} A={:.5} ±{:.5} ±{:.5} ref R {r} T {tt}  {:.0} ph/s book {:e}", s.r_specular + s.r_diffuse, s.r_specular, s.t_total, s.absorbed, s.stderr.r_diffuse, s.stderr.t_total, s.photons_per_s, s.bookkeeping_error);
    }
}
