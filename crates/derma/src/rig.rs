//! `derma rig …`: the skin appearance rig of Jimenez et al. 2010 — build a basis from a neutral
//! hemoglobin map and targets, evaluate frames, animate weight curves, transfer to another
//! character, list the built-in expression library.

use crate::output::line;
use crate::progress::Bars;
use crate::rig_args::{
    AnimateArgs, BuildArgs, EvalArgs, FormatArg, ModeArg, RigCommand, TransferArgs,
};
use anyhow::Result;
use derma_rig::frame_job::FrameJob;
use derma_rig::from_files::{self, BuildFiles, OnMesh};
use derma_rig::sequence::{render_sequence, FrameFormat, SequenceOptions};
use derma_rig::{expression, BasisOptions, TransferMode};
use std::time::Instant;

pub fn run(cmd: RigCommand, bars: &Bars) -> Result<()> {
    match cmd {
        RigCommand::Build(a) => build(a, bars),
        RigCommand::Eval(a) => eval(a, bars),
        RigCommand::Animate(a) => animate(a, bars),
        RigCommand::Transfer(a) => transfer(a, bars),
        RigCommand::Library => {
            for e in &expression::LIBRARY {
                line(format!(
                    "{:<10} {:<10} global ×{:<5} {}",
                    e.name,
                    format!("{:?}", e.kind).to_lowercase(),
                    e.global_scale,
                    e.notes
                ))?;
            }
            line("(authored approximations of Jimenez et al. 2010's observations on derma's built-in head, not measurements)")
        }
    }
}

fn build(a: BuildArgs, bars: &Bars) -> Result<()> {
    let t0 = Instant::now();
    if a.head.head.is_some() && a.mesh.is_none() {
        anyhow::bail!(
            "--head places the built-in library on your own mesh's UVs, given with --mesh; a fitted head's own set (derma skin --head) shares derma's UVs and needs neither"
        );
    }
    let files = BuildFiles {
        character: a.character.files(),
        targets: a.targets,
        builtin: a.builtin,
        globals: a.globals,
        lut: a.lut,
        on_mesh: a.mesh.map(|mesh| OnMesh {
            head: a.head.head.expect("clap: --mesh requires --head"),
            mesh,
        }),
    };
    let opts = BasisOptions {
        radius: a.radius,
        basis_size: (a.basis_size, a.basis_size),
        sigma_floor: a.sigma_floor,
    };
    let (rig, json) = from_files::build(&files, &opts, &a.out, bars)?;
    let (w, h) = rig.size();
    bars.say(format!(
        "rig: {} targets ({}), {w}×{h} maps, basis {}×{}, r = {} texels, σ floor {:.3e}, colour {}, in {:.2} s → {}",
        json.targets.len(),
        json.targets.iter().map(|t| t.name.as_str()).collect::<Vec<_>>().join(", "),
        json.basis_size[0],
        json.basis_size[1],
        a.radius,
        rig.sigma_floor,
        match &rig.skin {
            Some(s) => format!("the set's skin re-shaded ('{}' appearance)", s.appearance),
            None => "the skin-colour LUT's (no set given)".into(),
        },
        t0.elapsed().as_secs_f64(),
        a.out.display()
    ));
    Ok(())
}

fn transfer(a: TransferArgs, bars: &Bars) -> Result<()> {
    let mode = match a.mode {
        ModeArg::Absolute => TransferMode::Absolute,
        ModeArg::Relative => TransferMode::Relative,
    };
    let character = a.character.files();
    let moved = from_files::transfer(&a.rig, &character, mode, a.sigma_floor, &a.out, bars)?;
    bars.say(format!(
        "transferred {} targets onto '{}'{} → {}",
        moved.targets.len(),
        character.neutral.display(),
        if moved.skin.is_some() {
            " (frames keep the set's skin)"
        } else {
            ""
        },
        a.out.display()
    ));
    Ok(())
}

fn eval(a: EvalArgs, bars: &Bars) -> Result<()> {
    let job = FrameJob {
        rig: a.rig,
        weights: a.weights,
        normalization: a.frame.normalization(),
        global_scale: a.frame.global_scale,
        melanin: a.frame.melanin,
        device: a.device.device,
        color: a.out,
        hemoglobin: a.hemoglobin,
        preview: a.preview,
    };
    let r = derma_rig::frame_job::run(&job, bars).map_err(weights_hint)?;
    line(format!(
        "weights: neutral={:.4}{} global scale {:.4}",
        r.neutral,
        r.targets
            .iter()
            .filter(|(_, x)| *x > 0.0)
            .map(|(name, x)| format!(", {name}={x:.4}"))
            .collect::<String>(),
        r.global_scale
    ))
}

fn animate(a: AnimateArgs, bars: &Bars) -> Result<()> {
    let t0 = Instant::now();
    from_files::check_out(&a.out, &[&a.rig, &a.curves])?;
    let opts = SequenceOptions {
        fps: a.fps,
        format: match a.format {
            FormatArg::Png => FrameFormat::Png,
            FormatArg::Exr => FrameFormat::Exr,
        },
        hemoglobin: a.hemoglobin,
        force: a.force,
        normalization: a.frame.normalization(),
        global_scale: a.frame.global_scale,
        melanin: a.frame.melanin.clone(),
    };
    let run = render_sequence(&a.rig, &a.curves, &opts, &a.out, bars).map_err(weights_hint)?;
    bars.finish();
    bars.say(format!(
        "{} frames at {} fps ({} already there) in {:.2} s → {}",
        run.frames,
        run.fps,
        run.kept,
        t0.elapsed().as_secs_f64(),
        a.out.display()
    ));
    Ok(())
}

/// A rig error, with the flag that rescales weights named when the weights were refused.
fn weights_hint(e: derma_rig::RigError) -> anyhow::Error {
    let weights = matches!(&e, derma_rig::RigError::Invalid { what, .. } if what == "weights");
    let e = anyhow::Error::new(e);
    if weights {
        e.context("the frame's weights (--normalize rescales weights that sum above one)")
    } else {
        e
    }
}
