//! `derma rig …`: the skin appearance rig of Jimenez et al. 2010 — build a basis from a neutral
//! hemoglobin map and targets, evaluate frames, animate weight curves, transfer to another
//! character, list the built-in expression library.

use crate::output::line;
use crate::progress::Bars;
use crate::rig_args::{
    AnimateArgs, BuildArgs, EvalArgs, FormatArg, ModeArg, RigCommand, TransferArgs,
};
use anyhow::{bail, Result};
use derma_rig::from_files::{self, BuildFiles};
use derma_rig::maps::{melanin_for, write_color, write_hemoglobin};
use derma_rig::sequence::{render_sequence, FrameFormat, SequenceOptions};
use derma_rig::weights::frame_weights;
use derma_rig::{expression, rig_dir, BasisOptions, TransferMode};
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
    let files = BuildFiles {
        character: a.character.files(),
        targets: a.targets,
        builtin: a.builtin,
        globals: a.globals,
        lut: a.lut,
    };
    let opts = BasisOptions {
        radius: a.radius,
        basis_size: (a.basis_size, a.basis_size),
        sigma_floor: a.sigma_floor,
    };
    let (rig, json) = from_files::build(&files, &opts, &a.out, bars)?;
    let (w, h) = rig.size();
    bars.say(format!(
        "rig: {} targets ({}), {w}×{h} maps, basis {}×{}, r = {} texels, σ floor {:.3e}, in {:.2} s → {}",
        json.targets.len(),
        json.targets.iter().map(|t| t.name.as_str()).collect::<Vec<_>>().join(", "),
        json.basis_size[0],
        json.basis_size[1],
        a.radius,
        rig.sigma_floor,
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
        "transferred {} targets onto '{}' → {}",
        moved.targets.len(),
        a.character.neutral.display(),
        a.out.display()
    ));
    Ok(())
}

fn eval(a: EvalArgs, bars: &Bars) -> Result<()> {
    if a.out.is_none() && a.hemoglobin.is_none() && a.preview.is_none() {
        bail!("nothing to write: give --out (colour), --hemoglobin and/or --preview");
    }
    let (rig, lut, _) = rig_dir::load(&a.rig)?;
    let (w, g) = frame_weights(
        &rig,
        &a.weights,
        a.frame.normalization(),
        a.frame.global_scale,
    )?;
    let wants_color = a.out.is_some() || a.preview.is_some();
    let melanin = wants_color
        .then(|| melanin_for(&rig, a.frame.melanin.as_deref(), &lut.options, bars))
        .transpose()?;
    let (h, rgb) =
        derma_rig::evaluate::evaluate_frame(&rig, &lut, &w, g, melanin.as_ref(), a.device.device)?;
    if let Some(p) = &a.hemoglobin {
        write_hemoglobin(p, &h, &lut.options)?;
    }
    if let Some(rgb) = &rgb {
        if let Some(p) = &a.out {
            write_color(p, rgb)?;
        }
        if let Some(p) = &a.preview {
            derma_rig::preview::write_preview(p, rgb, &h)?;
        }
    }
    line(format!(
        "weights: neutral={:.4}{} global scale {g:.4}",
        w[0],
        rig.targets
            .iter()
            .zip(&w[1..])
            .filter(|(_, x)| **x > 0.0)
            .map(|(t, x)| format!(", {}={x:.4}", t.name))
            .collect::<String>()
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
    let run = render_sequence(&a.rig, &a.curves, &opts, &a.out, bars)?;
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
