//! bio.exr's compression, speed against size (issue 15): the 12 half-float bio channels of the
//! built-in head at 4096² (`DERMA_BENCH_SIZE` to change) written uncompressed, RLE and ZIP by
//! derma's writer, and PIZ by the `exr` crate (derma does not write PIZ; its channels are
//! handed over as ready planar half floats, outside the timing). Sizes print before the timings.
//!
//! cargo bench -p derma-skin --bench exr_compression

use criterion::{criterion_group, criterion_main, Criterion};
use derma_core::exr_writer::ExrCompression;
use derma_skin::paint::BIO_CHANNELS;
use derma_skin::{SkinConfig, SkinGenerator};

fn bench(c: &mut Criterion) {
    let size: u32 = std::env::var("DERMA_BENCH_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4096);
    let set = SkinGenerator::new(SkinConfig {
        size,
        ..SkinConfig::default()
    })
    .run()
    .expect("the built-in head");
    let bio = &set.bio;
    let (w, h) = (bio.width, bio.height);
    let dir = std::env::temp_dir().join(format!("derma-exr-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let write = |comp: ExrCompression, path: &std::path::Path| {
        derma_skin::texture_set::write_bio_exr(path, bio, comp).unwrap()
    };
    // PIZ through the exr crate: planar half-float channels made once.
    let planar: Vec<(&str, Vec<half::f16>)> = BIO_CHANNELS
        .iter()
        .map(|(name, f)| {
            (
                *name,
                bio.texels
                    .iter()
                    .map(|s| half::f16::from_f32(f(s)))
                    .collect(),
            )
        })
        .collect();
    let piz = |path: &std::path::Path| {
        use exr::prelude::*;
        let list: Vec<AnyChannel<FlatSamples>> = planar
            .iter()
            .map(|(n, v)| AnyChannel::new(*n, FlatSamples::F16(v.clone())))
            .collect();
        let layer = Layer::new(
            (w, h),
            LayerAttributes::default(),
            Encoding {
                compression: Compression::PIZ,
                blocks: Blocks::ScanLines,
                line_order: LineOrder::Increasing,
            },
            AnyChannels::sort(list.into()),
        );
        Image::from_layer(layer).write().to_file(path).unwrap();
    };
    let raw = (w * h * 12 * 2) as f64 / 1e6;
    println!("bio.exr at {w}×{h}: {raw:.0} MB of half-float samples");
    for (name, comp) in [
        ("none", ExrCompression::None),
        ("rle", ExrCompression::Rle),
        ("zip", ExrCompression::Zip),
    ] {
        let p = dir.join(format!("{name}.exr"));
        write(comp, &p);
        let mb = std::fs::metadata(&p).unwrap().len() as f64 / 1e6;
        println!(
            "  {name:5} {mb:7.1} MB ({:.0} % of the samples)",
            100.0 * mb / raw
        );
    }
    let p = dir.join("piz.exr");
    piz(&p);
    let mb = std::fs::metadata(&p).unwrap().len() as f64 / 1e6;
    println!(
        "  piz   {mb:7.1} MB ({:.0} % of the samples)",
        100.0 * mb / raw
    );

    let mut g = c.benchmark_group(format!("bio_exr_{w}"));
    g.sample_size(10);
    for (name, comp) in [
        ("none", ExrCompression::None),
        ("rle", ExrCompression::Rle),
        ("zip", ExrCompression::Zip),
    ] {
        let p = dir.join(format!("{name}.exr"));
        g.bench_function(name, |b| b.iter(|| write(comp, &p)));
    }
    g.bench_function("piz_exr_crate", |b| b.iter(|| piz(&p)));
    g.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench);
criterion_main!(benches);
