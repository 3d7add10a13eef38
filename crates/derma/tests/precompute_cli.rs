//! Precompute on a cluster, as a scheduler runs it: four shards as concurrent processes into
//! one directory — their indices from a Slurm job array's environment, a Kubernetes Indexed
//! Job's and `--shard` — one killed mid-way and resumed, then `derma optics merge`; the table
//! equals a single process's byte for byte.

use crate::common;

use common::{run, s};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};

const GRID: &str = r#"
photons = 20000
seed = 5
brdf = [3, 3, 2]
profile_bins = 8
profile_d_max_mm = 4.0
[axes]
melanin = [0.02, 0.2]
pheomelanin = [0.3, 0.6]
blood = [0.01, 0.05]
oxygenation = [0.75, 0.9]
stratum_corneum_um = [10.0]
epidermis_um = [80.0]
"#;

fn precompute(grid: &Path, out: &Path, env: &[(&str, &str)], shard: Option<&str>) -> Child {
    // One worker thread per shard: four shards share the machine's cores.
    let mut env = env.to_vec();
    env.push(("RAYON_NUM_THREADS", "1"));
    let args = ["optics", "precompute", "--grid", s(grid), "--out", s(out)];
    let args = [&args[..], &["--device", "cpu", "--quiet"]].concat();
    common::spawn_shard(&args, &env, shard)
}

fn entries(dir: &Path, shard: usize) -> usize {
    std::fs::read_dir(dir.join("entries"))
        .map(|r| {
            r.filter_map(|e| e.ok())
                .filter_map(|e| {
                    let n = e.file_name().into_string().ok()?;
                    n.strip_suffix(".json")?.parse::<usize>().ok()
                })
                .filter(|i| i % 4 == shard - 1)
                .count()
        })
        .unwrap_or(0)
}

fn merge(dir: &Path, out: &Path) -> (Vec<u8>, Vec<u8>) {
    let st = Command::new(env!("CARGO_BIN_EXE_derma"))
        .args(["optics", "merge", s(dir), "--out", s(out), "--quiet"])
        .status()
        .unwrap();
    assert!(st.success());
    let side = PathBuf::from(format!("{}.json", out.display()));
    (std::fs::read(out).unwrap(), std::fs::read(side).unwrap())
}

#[test]
fn four_concurrent_shards_one_killed_and_resumed_merge_to_the_single_process_table() {
    let d = common::tmp("precompute", "cluster");
    let grid = d.join("grid.toml");
    std::fs::write(&grid, GRID).unwrap();

    let single = d.join("single");
    assert!(precompute(&grid, &single, &[], None)
        .wait()
        .unwrap()
        .success());
    let want = merge(&single, &d.join("single.dtab"));

    let shared = d.join("shared");
    let slurm = |id: &'static str| {
        vec![
            ("SLURM_ARRAY_TASK_ID", id),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]
    };
    let k8s = [("JOB_COMPLETION_INDEX", "1"), ("DERMA_SHARD_COUNT", "4")];
    let mut first = precompute(&grid, &shared, &slurm("0"), None);
    let mut victim = precompute(&grid, &shared, &k8s, None);
    let mut third = precompute(&grid, &shared, &[], Some("3/4"));
    let mut fourth = precompute(&grid, &shared, &slurm("3"), None);
    // Kill shard 2/4 (the Indexed Job's index 1) once it has written its first entry.
    common::kill_when(
        &mut victim,
        || entries(&shared, 2) > 0,
        "shard 2 wrote nothing",
    );
    let done = entries(&shared, 2);
    assert!(
        done < 4,
        "shard 2 finished all its 4 entries before it was killed"
    );
    for c in [&mut first, &mut third, &mut fourth] {
        assert!(c.wait().unwrap().success());
    }
    for k in [1, 3, 4] {
        assert_eq!(entries(&shared, k), 4, "shard {k}");
    }
    // Merging now names what is missing.
    let (ok, _, err) = run(&[
        "optics",
        "merge",
        s(&shared),
        "--out",
        s(&d.join("partial.dtab")),
    ]);
    assert!(!ok && err.contains("missing"), "{err}");
    // The same Indexed Job pod again: it resumes, computing only what is left.
    assert!(precompute(&grid, &shared, &k8s, None)
        .wait()
        .unwrap()
        .success());
    assert_eq!(entries(&shared, 2), 4);
    let got = merge(&shared, &d.join("shared.dtab"));
    assert!(got.0 == want.0, "the merged tables differ");
    assert_eq!(got.1, want.1, "the tables' sidecars differ");
    println!("shard 2 killed after {done} of 4 entries, resumed; tables identical");
}
