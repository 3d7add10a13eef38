//! A short scripted sequence on the built-in head — gaze shifts on the saccade main sequence and
//! a full blink — rendered with the preview: a contact strip and an animated PNG.
//!
//! cargo run --release -p derma-eyes --example 01_eye_sequence [OUT_DIR]   (default: a temporary
//! directory; `docs/images` remakes the README's figures)

use derma_core::Map;
use derma_eyes::animate::{self, Drive};
use derma_eyes::blink::Blink;
use derma_eyes::evaluate::{Evaluator, Frame};
use derma_eyes::idle::Fixation;
use derma_eyes::render::{self, Stage};
use derma_eyes::rigdata::Rig;
use derma_eyes::*;

fn main() -> Result<()> {
    let dir = std::env::args()
        .nth(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("derma-eyes-sequence"));
    std::fs::create_dir_all(&dir).map_err(|source| derma_core::CoreError::Write {
        path: dir.clone(),
        source,
    })?;
    let head = derma_head::Head::builtin();
    let rig = Rig::new(head)?;
    let model = EyeModel::fit(&rig.samples(300, 1), Components::default())?;
    let ev = Evaluator::new(&model, &rig.region, head, sliding::THICKNESS)?;
    let fix = |start: f32, h: f32, v: f32| Fixation {
        start,
        gaze: Fick { h, v, t: 0.0 },
        mutual: false,
    };
    let drive = Drive {
        seconds: 2.9,
        fps: 12.0,
        fixations: Some(vec![
            fix(0.0, 0.0, 0.0),
            fix(0.3, 20.0, 0.0),
            fix(0.85, 0.0, -28.0),
            fix(1.9, -18.0, 15.0),
            fix(2.5, 0.0, 0.0),
        ]),
        blinks: Some(vec![Blink {
            start: 1.3,
            amplitude: 45.0,
            down: 0.086,
            up: 0.123,
        }]),
        ..Drive::default()
    };
    let centres = [head.eyes[0].centre, head.eyes[1].centre];
    let samples = animate::timeline(
        &model,
        centres,
        head.eyes[0].radius + sliding::THICKNESS,
        &drive,
    );
    let skin = derma_eyes::surface::Skin::of_head(head);
    let stage = Stage::new(head, &rig.region, &skin, None);
    let mut f = Frame::default();
    let mut frames = Vec::new();
    let mut imgs = Vec::new();
    for s in &samples {
        ev.frame(&s.gaze, &mut f);
        let img = stage.render(&f, s.gaze.eyes.map(|a| a.rotation()), 360);
        frames.push(render::srgb8(&img));
        imgs.push(img);
    }
    let (w, h) = (imgs[0][0].width(), imgs[0][0].height());
    derma_core::image_io::write_apng(&dir.join("eyes-sequence-anim.png"), &frames, w, h, 12)?;
    // The strip: primary, left, down, mid-blink, closed, up-right.
    let pick = [0usize, 7, 12, 16, 17, 26];
    let strip = [0, 1, 2].map(|c| {
        let mut out = vec![0.0f32; 2 * w * 3 * h];
        for (k, &i) in pick.iter().enumerate() {
            let (ox, oy) = ((k % 2) * w, (k / 2) * h);
            for y in 0..h {
                for x in 0..w {
                    out[(oy + y) * 2 * w + ox + x] = imgs[i][c].get(x, y);
                }
            }
        }
        Map::from_vec(2 * w, 3 * h, out).expect("size")
    });
    derma_core::image_io::write_png8_srgb(
        &dir.join("eyes-sequence.png"),
        &[&strip[0], &strip[1], &strip[2]],
    )?;
    for (i, s) in samples.iter().enumerate() {
        println!(
            "{i:2} t {:.2} s  gaze ({:6.1}, {:6.1})°  closure {:.2}",
            s.t, s.cyclopean.h, s.cyclopean.v, s.closure
        );
    }
    println!("wrote {}", dir.display());
    Ok(())
}
