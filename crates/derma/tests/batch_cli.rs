//! `derma batch` as a cluster runs it: 8 identities at 256² as four concurrent shards into one
//! directory — their indices from a Slurm job array's environment, a Kubernetes Indexed Job's and
//! `--shard` — one killed while painting and resumed, then `--merge`; every file equals a single
//! process's byte for byte. And the errors a user meets: a bad spec, another spec in the same
//! directory, an incomplete or altered batch at merge.

use crate::common;

use common::{run, s};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};

const SPEC: &str = r#"
count = 8
seed = 11
size = 256
age_years = [25.0, 75.0]
"#;

fn batch(spec: &Path, out: &Path, env: &[(&str, &str)], shard: Option<&str>) -> Child {
    common::spawn_shard(&["batch", s(spec), "--out", s(out), "--quiet"], env, shard)
}

/// Every file under `dir` but the sets' report.json (it carries timings) and the manifest.
fn files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if !p.ends_with("report.json") && !p.ends_with("manifest.jsonl") {
                out.insert(
                    p.strip_prefix(dir).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    out
}

/// How many unfinished directories of identity `dir` are in `out`.
fn partials(out: &Path, dir: &str) -> usize {
    std::fs::read_dir(out)
        .map(|r| {
            r.filter_map(|e| e.ok())
                .filter(|e| {
                    e.file_name()
                        .to_string_lossy()
                        .starts_with(&format!("{dir}.partial."))
                })
                .count()
        })
        .unwrap_or(0)
}

/// manifest.jsonl's lines without their timings.
fn manifest(dir: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(dir.join("manifest.jsonl"))
        .unwrap()
        .lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            let secs = v.as_object_mut().unwrap().remove("seconds").unwrap();
            assert!(secs.as_f64().unwrap() > 0.0, "{l}");
            v
        })
        .collect()
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn four_shards_one_killed_and_resumed_equal_one_process_byte_for_byte() {
    let d = common::tmp("batch", "cluster");
    let spec = d.join("spec.toml");
    std::fs::write(&spec, SPEC).unwrap();

    let single = d.join("single");
    assert!(batch(&spec, &single, &[], None).wait().unwrap().success());
    let (ok, _, err) = run(&["batch", "--merge", "--out", s(&single)]);
    assert!(ok, "{err}");

    let shared = d.join("shared");
    let slurm = |id: &'static str| {
        vec![
            ("SLURM_ARRAY_TASK_ID", id),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_MAX", "4"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]
    };
    let k8s = [("JOB_COMPLETION_INDEX", "1"), ("DERMA_SHARD_COUNT", "4")];
    // Shard 3/4 owns identities 2 and 6: an unfinished directory a killed pod on another host
    // left is waiting, with a stray file that must not reach the result.
    let foreign = shared.join("000002.partial.other-host.1.0");
    std::fs::create_dir_all(&foreign).unwrap();
    std::fs::write(foreign.join("base_color.png"), b"half").unwrap();
    let mut first = batch(&spec, &shared, &slurm("1"), None);
    let mut victim = batch(&spec, &shared, &k8s, None);
    let mut third = batch(&spec, &shared, &[], Some("3/4"));
    let mut fourth = batch(&spec, &shared, &slurm("4"), None);
    // Kill shard 2/4 (identities 1 and 5) while it paints its first identity.
    common::kill_when(
        &mut victim,
        || partials(&shared, "000001") > 0,
        "shard 2 never began",
    );
    for c in [&mut first, &mut third, &mut fourth] {
        assert!(c.wait().unwrap().success());
    }
    assert!(
        !shared.join("000001").exists(),
        "killed, yet identity 1 is complete"
    );
    // Merging now names what is missing.
    let (ok, _, err) = run(&["batch", "--merge", "--out", s(&shared)]);
    assert!(!ok && err.contains("000001: missing"), "{err}");
    assert!(
        err.contains("000005: missing") && err.contains("2 of 8"),
        "{err}"
    );
    assert_eq!(
        partials(&shared, "000001"),
        1,
        "the killed shard's unfinished directory"
    );
    // The same Indexed Job pod again: it removes its ended run's directory and resumes.
    assert!(batch(&spec, &shared, &k8s, None).wait().unwrap().success());
    assert_eq!(partials(&shared, "000001"), 0);
    assert!(
        foreign.is_dir(),
        "another host's directory is left to its writer or the merge"
    );
    let (ok, _, err) = run(&["batch", "--merge", "--out", s(&shared)]);
    assert!(ok, "{err}");
    assert!(
        !foreign.exists(),
        "the merge of a complete batch removes what was left"
    );

    let (want, got) = (files(&single), files(&shared));
    assert_eq!(
        want.keys().collect::<Vec<_>>(),
        got.keys().collect::<Vec<_>>()
    );
    // Each set: its 18 files but report.json, and identity.json; and the spec.
    assert_eq!(want.len(), 8 * 19 + 1);
    for (p, bytes) in &want {
        assert!(bytes == &got[p], "{} differs", p.display());
    }
    let lines = manifest(&shared);
    assert_eq!(lines, manifest(&single));
    // Each line names its identity's draws, and they vary across the batch.
    assert_eq!(lines.len(), 8);
    for (i, l) in lines.iter().enumerate() {
        assert_eq!(l["index"], i);
        let age = l["age_years"].as_f64().unwrap();
        assert!((25.0..=75.0).contains(&age), "{l}");
        assert!(l["files"]["base_color.png"].as_str().unwrap().len() == 64);
    }
    let seeds: std::collections::BTreeSet<u64> =
        lines.iter().map(|l| l["seed"].as_u64().unwrap()).collect();
    assert_eq!(seeds.len(), 8);
}

#[test]
fn a_batch_names_what_is_wrong() {
    let d = common::tmp("batch", "errors");
    let bad = |text: &str, want: &[&str]| {
        let spec = d.join("bad.toml");
        std::fs::write(&spec, text).unwrap();
        let (ok, _, err) = run(&["batch", s(&spec), "--out", s(&d.join("bad"))]);
        assert!(!ok, "{text}");
        for w in want {
            assert!(err.contains(w), "{text}: {err}");
        }
    };
    bad(
        "count = 2\npresets = [\"beige\"]",
        &["presets", "'beige'", "very-light"],
    );
    bad("count = 0", &["count", "at least one"]);
    bad("count = 2\nmale = 1.5", &["male", "1.5"]);
    bad("count = 2\nsize = []", &["size", "empty"]);
    bad("count = 2\nsize = [64, 64]", &["size", "twice"]);
    bad("count = 2\nsize = 8", &["size", "8 texels"]);
    bad(
        "count = 2\nita_deg = [40.0, 10.0]",
        &["ita_deg", "min ≤ max"],
    );
    bad(
        "count = 2\nmeshes = [\"a.obj\"]\nheads = [\"h\"]",
        &["meshes or heads"],
    );
    bad("count = 2\ncolour = 3", &["unknown field", "colour"]);
    bad(
        "count = 2\noutputs = [\"albedo.png\"]",
        &["outputs", "'albedo.png'", "base_color.png"],
    );
    bad(
        "count = 1\nsize = 64\nmeshes = [\"nowhere.obj\"]",
        &["nowhere.obj", "does not exist"],
    );

    // A directory holds one batch: another spec is refused before any work.
    let spec = d.join("one.toml");
    let keep = "outputs = [\"base_color.png\", \"roughness.png\"]";
    std::fs::write(&spec, format!("count = 1\nsize = 64\nseed = 1\n{keep}")).unwrap();
    let out = d.join("one");
    let (ok, _, err) = run(&["batch", s(&spec), "--out", s(&out)]);
    assert!(ok, "{err}");
    // Only the outputs asked for, the report (the manifest's timings) and the record.
    let mut kept: Vec<String> = std::fs::read_dir(out.join("000000"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    kept.sort();
    assert_eq!(
        kept,
        [
            "base_color.png",
            "identity.json",
            "report.json",
            "roughness.png"
        ]
    );
    std::fs::write(&spec, format!("count = 1\nsize = 64\nseed = 2\n{keep}")).unwrap();
    let (ok, _, err) = run(&["batch", s(&spec), "--out", s(&out)]);
    assert!(!ok && err.contains("another batch"), "{err}");
    // An altered file fails the merge, naming it.
    std::fs::write(out.join("000000/roughness.png"), b"not the painted file").unwrap();
    let (ok, _, err) = run(&["batch", "--merge", "--out", s(&out)]);
    assert!(
        !ok && err.contains("000000") && err.contains("roughness.png"),
        "{err}"
    );
    // Merging a directory that holds no batch names the spec it looked for.
    let (ok, _, err) = run(&["batch", "--merge", "--out", s(&d.join("none"))]);
    assert!(!ok && err.contains("batch.toml"), "{err}");
}

#[test]
fn a_spec_s_config_keeps_its_own_relative_paths() {
    // The config names its mesh relative to itself; the batch runs from elsewhere, with the
    // spec's path spelled relative to the working directory.
    let d = common::tmp("batch", "config");
    std::fs::create_dir_all(d.join("cfg")).unwrap();
    std::fs::write(d.join("cfg/quad.glb"), derma_test_support::quad_glb()).unwrap();
    std::fs::write(
        d.join("cfg/skin.toml"),
        "[surface]\nkind = \"mesh\"\nmesh = \"quad.glb\"\n",
    )
    .unwrap();
    std::fs::write(
        d.join("spec.toml"),
        "count = 1\nsize = 64\nconfig = \"cfg/skin.toml\"\noutputs = [\"base_color.png\"]\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_derma"))
        .current_dir(&d)
        .args(["batch", "spec.toml", "--out", "out", "--quiet"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("out/000000/report.json")).unwrap()).unwrap();
    let mesh = report["inputs"]["mesh"]["path"].as_str().unwrap();
    assert!(mesh.ends_with("quad.glb"), "{mesh}");
    assert!(
        report["inputs"]["config"].is_object(),
        "{}",
        report["inputs"]
    );
    // The same spec by its absolute path is the same batch: nothing is refused or redone.
    let (ok, _, err) = run(&["batch", s(&d.join("spec.toml")), "--out", s(&d.join("out"))]);
    assert!(ok, "{err}");
}

#[test]
#[ignore = "slow: scripts/test_slow.sh"]
fn a_list_of_sizes_paints_each_identity_at_each() {
    let d = common::tmp("batch", "sizes");
    let spec = d.join("spec.toml");
    std::fs::write(
        &spec,
        "count = 2\nseed = 4\nsize = [64, 128]\noutputs = [\"base_color.png\", \"melanin.exr\"]\n",
    )
    .unwrap();
    let out = d.join("out");
    let (ok, _, err) = run(&["batch", s(&spec), "--out", s(&out)]);
    assert!(ok, "{err}");
    let (ok, _, err) = run(&["batch", "--merge", "--out", s(&out)]);
    assert!(ok, "{err}");
    let lines = manifest(&out);
    for (i, l) in lines.iter().enumerate() {
        let files: Vec<&String> = l["files"].as_object().unwrap().keys().collect();
        assert_eq!(
            files,
            [
                "128/base_color.png",
                "128/melanin.exr",
                "64/base_color.png",
                "64/melanin.exr"
            ],
            "{l}"
        );
        assert_eq!(l["size"], serde_json::json!([64, 128]));
        for n in [64u32, 128] {
            let dir = out.join(format!("{i:06}/{n}"));
            let img = derma_core::image_io::read_rgb(&dir.join("base_color.png")).unwrap();
            assert_eq!(img.channels[0].width(), n as usize);
            assert!(dir.join("report.json").is_file());
        }
    }
    // The same person at both sizes: the one seed in both reports.
    let seed = |n: u32| -> serde_json::Value {
        let r = std::fs::read(out.join(format!("000001/{n}/report.json"))).unwrap();
        serde_json::from_slice::<serde_json::Value>(&r).unwrap()["seed"].clone()
    };
    assert_eq!(seed(64), seed(128));
    assert_eq!(seed(64), lines[1]["seed"]);
}
