use derma_photo::synthetic::*;
use derma_photo::*;
use std::time::Instant;
fn main() {
    let out = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or("/tmp/probe_bake".into()));
    std::fs::create_dir_all(&out).unwrap();
    let head = derma_head::Head::builtin();
    let lut = derma_shading::skin_color_lut::SkinColorLut::builtin();
    let t0 = Instant::now();
    let disc = face_disc(head).unwrap();
    let u = unwrap::unwrap(
        &disc,
        &unwrap::UnwrapOptions {
            view: Some(glam::Vec3::NEG_Z),
            ..Default::default()
        },
    )
    .unwrap();
    println!("unwrap {:?} {:.2}s", u.stretch, t0.elapsed().as_secs_f64());
    let mesh = u.mesh;
    let bvh = derma_core::bvh::Bvh::new(&mesh.positions, &mesh.triangles);
    let albedo = |p: glam::Vec3| {
        let (m, h) = chromophores_at(p, 1);
        lut.lookup(m as f64, h as f64).map(|v| v as f32)
    };
    let mut photos = Vec::new();
    let mut pts = Vec::new();
    let feats = feature_points(head, &mesh);
    let t0 = Instant::now();
    for (i, v) in default_views().iter().enumerate() {
        let cam = camera_for(head, v, 1200, 900, 550.0);
        let img = render(&mesh, &bvh, &cam, v, &albedo);
        img.write(&out.join(format!("photo{i}.png"))).unwrap();
        pts.push(clicked_points(
            &feats,
            &bvh,
            &cam,
            &format!("photo{i}"),
            1.5,
            i as u64,
        ));
        photos.push(photo::Photo {
            name: format!("photo{i}"),
            image: img,
            camera: cam,
        });
    }
    println!(
        "render {:.2}s; points {:?}",
        t0.elapsed().as_secs_f64(),
        pts.iter().map(|p| p.points.len()).collect::<Vec<_>>()
    );
    let res = resection::resect(&pts, &resection::ResectionOptions::default()).unwrap();
    for (r, p) in res.iter().zip(&photos) {
        println!(
            "{} rms {:.2} f {:.1} (true {:.1}) centre err {:.2} mm",
            r.photo,
            r.rms_px,
            r.camera.focal_px,
            p.camera.focal_px,
            (r.camera.centre() - p.camera.centre()).length()
        );
    }
    for (mb, gain) in [(false, false), (false, true), (true, true)] {
        let t0 = Instant::now();
        let recovered: Vec<photo::Photo> = photos
            .iter()
            .zip(&res)
            .map(|(p, r)| photo::Photo {
                camera: r.camera,
                ..p.clone()
            })
            .collect();
        let b = bake::bake(
            &mesh,
            &recovered,
            &bake::BakeOptions {
                size: 1024,
                multiband: mb,
                gain_compensation: gain,
                ..Default::default()
            },
            &derma_core::Silent,
        )
        .unwrap();
        println!(
            "bake mb {mb} gain {gain}: {:.2}s {:?} cases {:?}",
            t0.elapsed().as_secs_f64(),
            evaluate(&mesh, &b, &albedo),
            b.report.triangle_cases
        );
        b.texture
            .write(&out.join(format!("baked_mb{mb}_gain{gain}.png")))
            .unwrap();
        if mb {
            let t0 = Instant::now();
            let mask: Vec<bool> = b.source.iter().map(|s| (*s as usize) < 5).collect();
            let sel: Vec<[f32; 3]> = b
                .texture
                .data
                .iter()
                .zip(&mask)
                .filter(|(_, m)| **m)
                .map(|(c, _)| *c)
                .collect();
            let e = chromophores::fit_exposure(&lut, &sel);
            for e in [e] {
                let c = chromophores::invert(&lut, &b.texture, Some(&mask), e).unwrap();
                let raster = derma_core::raster::UvRaster::new(&mesh, 1024, 1024);
                let (mut em, mut eh, mut k) = (0.0, 0.0, 0);
                for i in 0..1024 * 1024 {
                    if mask[i] {
                        let (m, h) = chromophores_at(raster.position[i], 1);
                        em += (c.melanin.data()[i] - m).abs() as f64;
                        eh += (c.hemoglobin.data()[i] - h).abs() as f64;
                        k += 1;
                    }
                }
                println!(
                    "chromophores {:.2}s {:?} mean |dm| {:.4} |dh| {:.4}",
                    t0.elapsed().as_secs_f64(),
                    c.report,
                    em / k as f64,
                    eh / k as f64
                );
            }
            let c = chromophores::invert(&lut, &b.texture, Some(&mask), e).unwrap();
            derma_core::image_io::write_png8(&out.join("melanin.png"), &[&c.melanin]).unwrap();
            derma_core::image_io::write_png8(&out.join("hemoglobin.png"), &[&c.hemoglobin])
                .unwrap();
        }
    }
    // Truth texture
    let raster = derma_core::raster::UvRaster::new(&mesh, 1024, 1024);
    let truth = photo::RgbImage {
        width: 1024,
        height: 1024,
        data: (0..1024 * 1024)
            .map(|i| {
                if raster.covered(i) {
                    albedo(raster.position[i])
                } else {
                    [0.0; 3]
                }
            })
            .collect(),
    };
    truth.write(&out.join("truth.png")).unwrap();
}
fn _unused() {}
