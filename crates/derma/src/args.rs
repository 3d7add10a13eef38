//! The flag values every command shares, parsed once: `--device`, `--head`, sizes (`1024`, `1920x1080`),
//! sizes in mm (`40x30`), lists of numbers (`10,-5`), and `NAME=VALUE` items; each error names
//! the value.

use std::path::PathBuf;
use std::str::FromStr;

/// `N` or `WxH` (also `WXH`) of type `T`, each side accepted by `ok`; `what` describes the form
/// in errors.
fn two_sides<T: FromStr + Copy>(
    s: &str,
    ok: impl Fn(T) -> bool,
    what: &str,
) -> Result<(T, T), String> {
    let side = |v: &str| v.trim().parse::<T>().ok().filter(|&n| ok(n));
    let parsed = match s.split_once(['x', 'X']) {
        Some((w, h)) => side(w).zip(side(h)),
        None => side(s).map(|n| (n, n)),
    };
    parsed.ok_or_else(|| format!("'{s}': expected {what}"))
}

/// A size in texels or pixels: `N` or `WxH`, positive integers.
pub fn size(s: &str) -> Result<(u32, u32), String> {
    two_sides(
        s,
        |n: u32| n > 0,
        "a size W or WxH in positive integers, e.g. 1024 or 1920x1080",
    )
}

/// A rendered frame's size: as [`size`], each side 16 to 8192 pixels.
pub fn frame_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = size(s)?;
    if !(16..=8192).contains(&w) || !(16..=8192).contains(&h) {
        return Err(format!("size '{s}': each side must be 16 to 8192 pixels"));
    }
    Ok((w, h))
}

/// A size in millimetres: `W` or `WxH`, positive finite numbers.
pub fn mm_size(s: &str) -> Result<[f32; 2], String> {
    two_sides(
        s,
        |v: f32| v.is_finite() && v > 0.0,
        "a size in mm such as 40 or 40x30",
    )
    .map(|(w, h)| [w, h])
}

/// `n` comma-separated finite numbers of type `T` (each parsed as `T`, so rounded once).
fn numbers_of<T: FromStr>(
    s: &str,
    n: usize,
    finite: impl Fn(&T) -> bool,
) -> Result<Vec<T>, String> {
    let v: Option<Vec<T>> = s
        .split(',')
        .map(|x| x.trim().parse::<T>().ok().filter(&finite))
        .collect();
    match v {
        Some(v) if v.len() == n => Ok(v),
        _ => Err(format!(
            "'{s}': expected {n} comma-separated finite numbers"
        )),
    }
}

/// `n` comma-separated finite numbers.
pub fn numbers(s: &str, n: usize) -> Result<Vec<f64>, String> {
    numbers_of(s, n, |v: &f64| v.is_finite())
}

/// Two numbers `A,B` in single precision (a gaze's yaw and pitch).
pub fn pair(s: &str) -> Result<(f32, f32), String> {
    let v = numbers_of(s, 2, |v: &f32| v.is_finite())?;
    Ok((v[0], v[1]))
}

/// A number in [0, 1] (a lid closure, a weight).
pub fn unit_interval(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}': expected a number from 0 to 1")),
    }
}

/// A point `X,Y` (pixels).
pub fn point(s: &str) -> Result<[f64; 2], String> {
    let v = numbers(s, 2)?;
    Ok([v[0], v[1]])
}

/// `none` (or `auto`, as `word` says) for None, else [`numbers`]: an optional vector flag.
pub fn optional_numbers(s: &str, word: &str, n: usize) -> Result<Option<Vec<f64>>, String> {
    if s.trim().eq_ignore_ascii_case(word) {
        Ok(None)
    } else {
        numbers(s, n)
            .map(Some)
            .map_err(|e| format!("{e}, or '{word}'"))
    }
}

/// `NAME=VALUE`, a name of letters, digits, '_' or '-'; `form` describes the whole in errors.
pub fn named<T: FromStr>(s: &str, form: &str) -> Result<(String, T), String> {
    let (n, v) = s
        .split_once('=')
        .ok_or_else(|| format!("'{s}': expected {form}"))?;
    let n = n.trim();
    if n.is_empty()
        || !n
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(format!(
            "'{s}': the name '{n}' must be letters, digits, '_' or '-' ({form})"
        ));
    }
    let v = v
        .trim()
        .parse::<T>()
        .map_err(|_| format!("'{s}': expected {form}"))?;
    Ok((n.to_string(), v))
}

/// `NAME=FILE`.
pub fn named_file(s: &str) -> Result<(String, PathBuf), String> {
    named(s, "NAME=FILE, e.g. height=h.png")
}

/// `NAME=S`, a name and a number.
pub fn named_number(s: &str) -> Result<(String, f32), String> {
    let (n, v) = named::<f32>(s, "NAME=S, a name and a number")?;
    if !v.is_finite() {
        return Err(format!("'{s}': {v} is not a finite number"));
    }
    Ok((n, v))
}

/// `NAME=FILE[,NAME=FILE…]`.
pub fn named_files(s: &str) -> Result<Vec<(String, PathBuf)>, String> {
    s.split(',')
        .filter(|t| !t.trim().is_empty())
        .map(|t| named_file(t).map_err(|e| format!("in '{s}': {e}")))
        .collect()
}

/// `--device`, the same on every command that can use a GPU.
#[derive(clap::Args, Clone, Copy)]
pub struct DeviceArg {
    /// Where to run: auto (a hardware GPU when there is one, else the CPU), cpu, or gpu (any
    /// adapter, software ones such as Mesa's lavapipe included; needs a build with the `gpu`
    /// feature).
    #[arg(long, default_value = "auto", value_parser = parse_device)]
    pub device: derma_core::gpu::Device,
}

/// `--head`, the same on every command that draws or paints a head.
#[derive(clap::Args, Clone, Default)]
pub struct HeadArg {
    /// A fitted head (the directory `derma head fit` wrote) instead of the built-in head: its
    /// shape, landmarks, regions, face units, globes, teeth and lashes.
    #[arg(long, value_name = "DIR")]
    pub head: Option<PathBuf>,
}

/// `--unit` and `--node`, the same on every command that reads a user's mesh.
#[derive(clap::Args, Clone, Default)]
pub struct MeshReadArg {
    /// The mesh's unit: auto (`head fit`: found from the face; with --head, the unit its fit
    /// found; else the one of mm, cm, m that makes it head-sized), mm, cm, m, or fit (its
    /// largest extent made an adult head's). A unit that contradicts the fitted head's is
    /// refused.
    #[arg(long, value_name = "auto|mm|cm|m|fit")]
    pub unit: Option<String>,
    /// The part of a mesh file of several to read: a node, mesh or material name. Default: the
    /// skin, chosen by name and size (eyes, teeth, lashes, brows and hair left out; the node
    /// named head or face first, else the largest); the choice is reported.
    #[arg(long, value_name = "NAME")]
    pub node: Option<String>,
}

impl MeshReadArg {
    /// The unit asked for (`auto` when none).
    pub fn head_unit(&self) -> anyhow::Result<derma_core::head_mesh::HeadUnit> {
        let u = self.unit.as_deref().unwrap_or("auto");
        derma_core::head_mesh::HeadUnit::parse(u)
            .ok_or_else(|| anyhow::anyhow!("--unit {u}: expected auto, mm, cm, m or fit"))
    }

    /// The part asked for.
    pub fn part(&self) -> derma_core::mesh_parts::PartChoice {
        match &self.node {
            Some(n) => derma_core::mesh_parts::PartChoice::Named(n.clone()),
            None => derma_core::mesh_parts::PartChoice::Auto,
        }
    }
}

/// `--shard`, the same on every command that splits its work over a cluster job.
#[derive(clap::Args, Clone, Default)]
pub struct ShardArg {
    /// This process's share, k/n (1-based). Default: from the scheduler's environment (a Slurm
    /// job array's SLURM_ARRAY_TASK_ID, a Kubernetes Indexed Job's JOB_COMPLETION_INDEX with
    /// DERMA_SHARD_COUNT), else all of it.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
}

impl ShardArg {
    /// The shard and where it came from (the flag, or derma-core's reading of the environment).
    pub fn resolve(&self) -> derma_core::Result<(derma_core::shard::Shard, &'static str)> {
        match &self.shard {
            Some(s) => Ok((derma_core::shard::Shard::parse(s)?, "--shard")),
            None => derma_core::shard::Shard::from_env(|k| std::env::var(k).ok()),
        }
    }
}

fn parse_device(s: &str) -> Result<derma_core::gpu::Device, String> {
    s.parse()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_forms_each_command_documents() {
        assert_eq!(size("1024"), Ok((1024, 1024)));
        assert_eq!(size("1920x1080"), Ok((1920, 1080)));
        assert_eq!(size("64X32"), Ok((64, 32)));
        assert!(
            size("0").is_err() && size("-4").is_err() && size("4x").is_err() && size("").is_err()
        );
        assert!(frame_size("8").is_err() && frame_size("9000").is_err());
        assert_eq!(mm_size("40x30"), Ok([40.0, 30.0]));
        assert!(mm_size("nan").is_err() && mm_size("0x3").is_err() && mm_size("inf").is_err());
        assert_eq!(pair("10,-5"), Ok((10.0, -5.0)));
        assert!(pair("10").is_err() && pair("1,2,3").is_err() && pair("1,nan").is_err());
        assert_eq!(point("312.7, 80"), Ok([312.7, 80.0]));
        assert_eq!(optional_numbers("None", "none", 3), Ok(None));
        assert_eq!(
            optional_numbers("0,0,1", "none", 3),
            Ok(Some(vec![0.0, 0.0, 1.0]))
        );
        assert_eq!(named_number("smile=0.5"), Ok(("smile".into(), 0.5)));
        assert!(
            named_number("smile=inf").is_err()
                && named_number("=1").is_err()
                && named_number("a b=1").is_err()
        );
        assert_eq!(
            named_files("height=h.png, roughness=r.exr,"),
            Ok(vec![
                ("height".into(), PathBuf::from("h.png")),
                ("roughness".into(), PathBuf::from("r.exr"))
            ])
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Any text is a value or an error naming it, never a panic; what parses is in range.
        #[test]
        fn any_text_is_a_value_in_range_or_an_error_naming_it(s in "\\PC{0,24}") {
            for r in [size(&s).map(|_| ()), frame_size(&s).map(|_| ()), mm_size(&s).map(|_| ()),
                      pair(&s).map(|_| ()), point(&s).map(|_| ()), named_number(&s).map(|_| ()),
                      named_files(&s).map(|_| ())] {
                if let Err(e) = r {
                    prop_assert!(e.contains(&s), "{e:?} does not name {s:?}");
                }
            }
            if let Ok((w, h)) = size(&s) { prop_assert!(w > 0 && h > 0); }
            if let Ok([w, h]) = mm_size(&s) { prop_assert!(w > 0.0 && h > 0.0 && w.is_finite() && h.is_finite()); }
            if let Ok(v) = point(&s) { prop_assert!(v.iter().all(|x| x.is_finite())); }
        }

        /// Sizes written back as text parse to themselves.
        #[test]
        fn sizes_round_trip(w in 1u32..100_000, h in 1u32..100_000) {
            prop_assert_eq!(size(&format!("{w}x{h}")), Ok((w, h)));
            prop_assert_eq!(size(&w.to_string()), Ok((w, w)));
        }
    }
}
