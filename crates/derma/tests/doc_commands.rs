//! The README's and docs' fenced `derma …` lines, run as written at small sizes in one scratch
//! directory holding the files a user would have (a mesh, a scan, photos, exemplars), so a doc
//! line that drifts from the CLI (a renamed flag, a missing file, a wrong example) fails here.
//!
//! Both tests are slow checks (scripts/test_slow.sh; one minute for the quick lines, minutes for
//! the slow ones: precompute, match fit and lut, photo bake, head fit, the eye model's training
//! and renders): `cargo test --release -p derma --test suite doc_commands:: -- --ignored`.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// A fenced line of a document: its file, line number and the command (continuations joined,
/// the trailing comment dropped).
#[derive(Clone, Debug)]
struct DocLine {
    file: String,
    line: usize,
    command: String,
}

/// Every fenced line of README.md and docs/*.md that runs derma (or writes a file a later
/// line reads, as the README's `printf … > photo.toml`).
fn doc_lines() -> Vec<DocLine> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut files = vec![root.join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    let mut out = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        let (mut fenced, mut pending): (bool, Option<(usize, String)>) = (false, None);
        for (i, raw) in text.lines().enumerate() {
            if raw.trim_start().starts_with("```") {
                fenced = !fenced;
                continue;
            }
            if !fenced {
                continue;
            }
            let body = strip_comment(raw).trim().to_string();
            let (start, joined) = match pending.take() {
                Some((s, prev)) => (s, format!("{prev} {body}")),
                None if body.starts_with("derma ") || body.starts_with("printf ") => (i + 1, body),
                None => continue,
            };
            if let Some(cont) = joined.strip_suffix('\\') {
                pending = Some((start, cont.trim().to_string()));
            } else {
                out.push(DocLine {
                    file: name.clone(),
                    line: start,
                    command: joined,
                });
            }
        }
    }
    out
}

/// The line without its `# …` comment (a '#' outside quotes, after whitespace).
fn strip_comment(line: &str) -> &str {
    let mut quoted = false;
    let b = line.as_bytes();
    for (i, &c) in b.iter().enumerate() {
        match c {
            b'\'' | b'"' => quoted = !quoted,
            b'#' if !quoted && (i == 0 || b[i - 1] == b' ') => return &line[..i],
            _ => {}
        }
    }
    line
}

/// What becomes of a doc line here.
#[derive(Debug, PartialEq)]
enum Plan {
    /// Run in the test command.
    Quick,
    /// Run by the ignored test (minutes).
    Slow,
    /// Not run, and why.
    Skip(&'static str),
}

/// Lines that are not commands to run here, with the reason (matched by substring).
const SKIPPED: &[(&str, &str)] = &[
    ("─►", "a diagram of the pipeline, not a command"),
    ("derma view", "serves the viewer until stopped"),
    (
        "/shared/pre/",
        "a cluster's shared volume (the shard from the scheduler)",
    ),
    (
        "[--exemplar-channels",
        "a synopsis with optional parts in brackets",
    ),
    (
        "flushed=flushed/",
        "a second photo session (the flushed face) to bake first",
    ),
];

/// Slow lines (matched by substring): the ignored test runs them.
const SLOW: &[&str] = &[
    "optics precompute",
    "optics merge",
    "match fit",
    "match lut",
    "match surface",
    "--table table.dtab",
    "photo bake",
    "photo chromophores",
    "--neutral chromo/",
    "--mesh face_uv.obj --config photo.toml",
    "head fit",
    "--head fitted/",
    "eyes train",
    "eyes animate",
    "eyes sdf",
    "eyes synthetic",
    "--turntable",
    "rig animate",
    "batch ",
];

fn plan(l: &DocLine) -> Plan {
    if let Some((_, why)) = SKIPPED.iter().find(|(p, _)| l.command.contains(p)) {
        return Plan::Skip(why);
    }
    if l.command.contains("--device gpu") && !derma_core::gpu::BUILT {
        return Plan::Skip("needs the gpu feature (this build is CPU only)");
    }
    if SLOW.iter().any(|p| l.command.contains(p)) {
        Plan::Slow
    } else {
        Plan::Quick
    }
}

/// The command at a small size: skin sets 64², renders 96 × 54, synthesis 64², a few photons,
/// short animations; the values the docs give are otherwise kept.
fn small(cmd: &str) -> String {
    if !cmd.starts_with("derma ") {
        return cmd.to_string();
    }
    let mut words: Vec<String> = cmd.split_whitespace().map(String::from).collect();
    let sub = words.get(1).cloned().unwrap_or_default();
    let set = |words: &mut Vec<String>, flag: &str, value: &str, add: bool| match words
        .iter()
        .position(|w| w == flag)
    {
        Some(i) if i + 1 < words.len() => words[i + 1] = value.to_string(),
        _ if add => {
            words.push(flag.to_string());
            words.push(value.to_string());
        }
        _ => {}
    };
    let first_is_export = words.get(2).is_some_and(|w| w == "--export-template");
    match sub.as_str() {
        "skin" if !first_is_export && !cmd.contains("--print-config") => {
            set(&mut words, "--size", "64", true)
        }
        "render" => {
            set(&mut words, "--size", "96x54", true);
            set(&mut words, "--turntable", "2", false);
        }
        "synth" => {
            let v = if cmd.contains("1024x2048") {
                "64x128"
            } else {
                "64"
            };
            set(&mut words, "--size", v, true)
        }
        "optics" if cmd.contains("precompute") && !cmd.contains("--print-grid") => {
            // A 2-node grid with few photons (tiny-grid.toml); whole, not one shard, so the
            // merge that follows has every entry.
            set(&mut words, "--grid", "tiny-grid.toml", true);
            if let Some(i) = words.iter().position(|w| w == "--shard") {
                words.drain(i..(i + 2).min(words.len()));
            }
        }
        "optics" => set(&mut words, "--photons", "2000", cmd.contains("simulate")),
        "match" if cmd.contains(" lut") => {
            set(&mut words, "--size", "4", true);
            set(&mut words, "--photons", "500", true);
        }
        "photo" if cmd.contains("photo bake") => set(&mut words, "--size", "128", true),
        "photo" if cmd.contains("photo iris") || cmd.contains("photo teeth") => {
            set(&mut words, "--size", "64", true)
        }
        "eyes" => set(&mut words, "--seconds", "1", false),
        "rig" if cmd.contains("animate") => set(&mut words, "--fps", "4", false),
        _ => {}
    }
    words.join(" ")
}

/// The files a user has before following the docs, in `dir`.
fn fixtures(dir: &Path) {
    let derma = env!("CARGO_BIN_EXE_derma");
    let run = |args: &[&str]| {
        let out = Command::new(derma)
            .args(args)
            .arg("--quiet")
            .current_dir(dir)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "fixture {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    run(&["skin", "--export-template", "fixture-tpl/"]);
    let copy = |from: &Path, to: &str| {
        let to = dir.join(to);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(from, &to).unwrap_or_else(|e| panic!("{}: {e}", from.display()));
    };
    let tpl = dir.join("fixture-tpl");
    copy(&tpl.join("head.glb"), "head.glb");
    copy(&tpl.join("head.obj"), "head.obj");
    copy(&tpl.join("head.obj"), "scan.obj");
    copy(&tpl.join("freckles.png"), "fields/freckles.png");
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let skin = shared.join("skin_albedo_forehead_256x128.png");
    let height = shared.join("skin_displacement_forehead_512.png");
    copy(&shared.join("canonical_face_model.obj"), "face.obj");
    for name in [
        "forehead.png",
        "cheek.png",
        "nose.png",
        "albedo.png",
        "skin.png",
        "painting.png",
        "scan_albedo.png", // a photographed albedo on scan.obj's UVs (README, "Your own head")
    ] {
        copy(&skin, name);
    }
    copy(&height, "displacement.png");
    copy(&skin, "h.png"); // registered channels have the exemplar's size
    copy(&skin, "n.png");
    let guide = derma_core::Map::from_fn(64, 128, |i| if i < 64 * 64 { 0.0 } else { 1.0 });
    derma_core::image_io::write_png8(&dir.join("regions.png"), &[&guide]).unwrap();
    derma_photo::iris::synthetic_eye(240, 180, [118.0, 92.0], 48.0, 1)
        .write_linear(&dir.join("eye.png"))
        .unwrap();
    derma_photo::teeth::synthetic_smile(320, 160)
        .0
        .write_linear(&dir.join("smile.png"))
        .unwrap();
    run(&[
        "photo", "iris", "--photo", "eye.png", "--size", "64", "--out", "eye/",
    ]);
    copy(&dir.join("eye/eye.png"), "iris.png");
    run(&[
        "photo",
        "teeth",
        "--photo",
        "smile.png",
        "--size",
        "64",
        "--out",
        "teeth/",
    ]);
    run(&["skin", "--size", "64", "--seed", "2", "--out", "other/"]);
    std::fs::write(
        dir.join("curves.csv"),
        "time,happiness,anger\n0,0,0\n0.5,1,0\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("gaze.csv"),
        "time,h,v\n0,0,0\n0.5,10,-5\n1,-10,5\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("faces.toml"),
        "count = 2\nsize = 64\npresets = [\"light\", \"dark\"]\n",
    )
    .unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../derma-shading/data");
    copy(&data.join("match-table.dtab"), "old.dtab");
    copy(
        &data.join("match-grid.toml"),
        "crates/derma-shading/data/match-grid.toml",
    );
    std::fs::write(
        dir.join("tiny-grid.toml"),
        "photons = 2000\nseed = 1\nbrdf = [3, 3, 4]\nprofile_bins = 16\nprofile_d_max_mm = 8.0\n\n[axes]\nmelanin = [0.002, 0.2]\npheomelanin = [0.0, 1.0]\nblood = [0.002, 0.2]\noxygenation = [0.5, 1.0]\nstratum_corneum_um = [5.0, 50.0]\nepidermis_um = [20.0, 200.0]\n",
    )
    .unwrap();
}

/// Runs the lines `chosen` picks, in document order, in one scratch directory; fails listing
/// every line that failed.
fn run_lines(tag: &str, chosen: impl Fn(&Plan) -> bool) {
    let dir = common::tmp("doc", tag);
    fixtures(&dir);
    let bin = Path::new(env!("CARGO_BIN_EXE_derma")).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let (mut failed, mut ran, started) = (Vec::new(), 0, Instant::now());
    for l in doc_lines() {
        let p = plan(&l);
        if !chosen(&p) {
            continue;
        }
        let cmd = small(&l.command).replace("derma ", "derma --quiet ");
        let t = Instant::now();
        let out = Command::new("sh")
            .arg("-c")
            .arg(&cmd)
            .current_dir(&dir)
            .env("PATH", &path)
            .output()
            .unwrap();
        ran += 1;
        println!(
            "{:5.1} s  {}:{}  {cmd}",
            t.elapsed().as_secs_f64(),
            l.file,
            l.line
        );
        if !out.status.success() {
            failed.push(format!(
                "{}:{}: {cmd}\n    {}",
                l.file,
                l.line,
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
    }
    println!("{ran} lines in {:.1} s", started.elapsed().as_secs_f64());
    assert!(ran > 0);
    assert!(
        failed.is_empty(),
        "{} doc lines failed:\n{}",
        failed.len(),
        failed.join("\n")
    );
}

/// Every doc line is run somewhere or skipped for a stated reason, and the skipped ones stay few.
#[test]
fn every_doc_line_is_planned() {
    let lines = doc_lines();
    assert!(lines.len() > 80, "{} lines found", lines.len());
    let skipped: Vec<String> = lines
        .iter()
        .filter_map(|l| match plan(l) {
            Plan::Skip(why) => Some(format!("{}:{} ({why})", l.file, l.line)),
            _ => None,
        })
        .collect();
    println!("skipped: {skipped:#?}");
    assert!(skipped.len() <= 12, "{skipped:#?}");
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn the_docs_quick_lines_run_as_written() {
    run_lines("quick", |p| *p == Plan::Quick);
}

#[test]
#[ignore = "minutes: precompute, match fit and lut, photo bake, head fit, eye model"]
fn the_docs_slow_lines_run_as_written() {
    run_lines("all", |p| !matches!(p, Plan::Skip(_)))
}

/// Every flag's `[default: …]` in `derma … --help`, over every command and subcommand.
fn help_defaults() -> std::collections::BTreeMap<String, Vec<String>> {
    let help = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_derma"))
            .args(args)
            .arg("--help")
            .output()
            .unwrap();
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let commands = |text: &str| -> Vec<String> {
        text.split("Commands:")
            .nth(1)
            .map(|c| c.split("\n\n").next().unwrap_or(""))
            .unwrap_or("")
            .lines()
            .filter_map(|l| l.split_whitespace().next().map(String::from))
            .filter(|c| c != "help")
            .collect()
    };
    let mut texts = Vec::new();
    for c in commands(&help(&[])) {
        let t = help(&[&c]);
        for s in commands(&t) {
            texts.push(help(&[&c, &s]));
        }
        texts.push(t);
    }
    let mut out: std::collections::BTreeMap<String, Vec<String>> = Default::default();
    for t in texts {
        let mut flag: Option<String> = None;
        for l in t.lines() {
            let w = l.trim_start();
            let w = w
                .strip_prefix("-")
                .and_then(|x| x.split_once(", ").map(|(_, r)| r))
                .unwrap_or(w);
            if let Some(f) = w.strip_prefix("--") {
                flag = Some(f.split([' ', '=', '<']).next().unwrap_or("").to_string());
            }
            if let (Some(f), Some(d)) = (&flag, l.split("[default: ").nth(1)) {
                let v = d.split(']').next().unwrap_or("").to_string();
                out.entry(f.clone()).or_default().push(v);
            }
        }
    }
    out
}

/// A default the docs give a flag ("`--focal-deviation` … default 0.1") is the one its
/// `--help` shows (before: docs/photo.md said 0.1 where the help said 0.15).
#[test]
fn the_docs_defaults_are_the_helps() {
    let defaults = help_defaults();
    assert!(defaults.len() > 20, "{defaults:?}");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut docs = vec![root.join("README.md")];
    docs.extend(
        std::fs::read_dir(root.join("docs"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "md")),
    );
    let (mut checked, mut wrong) = (0, Vec::new());
    for d in docs {
        let text = std::fs::read_to_string(&d).unwrap();
        for (at, _) in text.match_indices("`--") {
            let rest = &text[at + 3..];
            let Some(end) = rest.find('`') else { continue };
            let flag = rest[..end].split([' ', '=']).next().unwrap_or("");
            let after: String = rest[end + 1..].chars().take(60).collect();
            let Some(i) = after.find("default ") else {
                continue;
            };
            if after[..i].contains('`') || after[..i].contains('.') && !after[..i].contains("e.g") {
                continue; // another flag, or another sentence, comes first
            }
            let value: String = after[i + 8..]
                .chars()
                .take_while(|c| c.is_ascii_digit() || *c == '.')
                .collect();
            let value = value.trim_end_matches('.');
            let Some(known) = defaults.get(flag) else {
                continue;
            };
            if value.is_empty() {
                continue;
            }
            checked += 1;
            let same = known
                .iter()
                .any(|k| k == value || k.parse::<f64>().ok() == value.parse::<f64>().ok());
            if !same {
                wrong.push(format!(
                    "{}: --{flag} default {value}; --help: {known:?}",
                    d.display()
                ));
            }
        }
    }
    println!("{checked} documented defaults checked");
    assert!(wrong.is_empty(), "{wrong:#?}");
}
