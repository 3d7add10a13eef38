//! Helpers shared by the CLI end-to-end tests: a fresh scratch directory and a quiet run of
//! the `derma` binary.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty directory for one test (`kind` and `tag` name it).
pub fn tmp(kind: &str, tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("derma-{kind}-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `derma ARGS --quiet`: (success, stdout, stderr).
pub fn run(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_derma"))
        .args(args)
        .arg("--quiet")
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Starts `derma ARGS` as one shard of a cluster job: only the scheduler variables in `env`
/// (Slurm arrays, Kubernetes Indexed Jobs; every other one derma reads is removed), and
/// `--shard K/N` when `shard` is given. (Only the sharding tests use it; each test binary
/// compiles this module.)
#[allow(dead_code)]
pub fn spawn_shard(
    args: &[&str],
    env: &[(&str, &str)],
    shard: Option<&str>,
) -> std::process::Child {
    let mut c = Command::new(env!("CARGO_BIN_EXE_derma"));
    c.args(args);
    if let Some(k) = shard {
        c.args(["--shard", k]);
    }
    for v in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_MAX",
        "SLURM_ARRAY_TASK_COUNT",
        "SLURM_ARRAY_TASK_STEP",
        "JOB_COMPLETION_INDEX",
        "DERMA_SHARD_COUNT",
    ] {
        c.env_remove(v);
    }
    c.envs(env.iter().copied()).spawn().unwrap()
}

/// Waits (two minutes at most) until `began` holds, then kills `child` and reaps it: a shard
/// killed mid-way, as a scheduler's preemption does.
#[allow(dead_code)]
pub fn kill_when(child: &mut std::process::Child, began: impl Fn() -> bool, what: &str) {
    let t0 = std::time::Instant::now();
    while !began() {
        assert!(t0.elapsed() < std::time::Duration::from_secs(120), "{what}");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
}
