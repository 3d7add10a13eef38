//! The split of work over a cluster job: shards from a flag or the scheduler's environment.
//! (Slurm job arrays, Kubernetes Indexed Jobs; precompute and batch both shard by it.)

use derma_core::shard::Shard;

#[test]
fn the_shard_comes_from_the_schedulers_environment() {
    let env = |pairs: &'static [(&'static str, &'static str)]| {
        move |k: &str| {
            pairs
                .iter()
                .find(|(n, _)| *n == k)
                .map(|(_, v)| v.to_string())
        }
    };
    let shard = |k, n| Shard { k, n };
    // Slurm: `sbatch --array=0-7` (ids from 0) and `--array=1-8` (from 1) give the same shards.
    let s = env(&[
        ("SLURM_ARRAY_TASK_ID", "3"),
        ("SLURM_ARRAY_TASK_MIN", "0"),
        ("SLURM_ARRAY_TASK_MAX", "7"),
        ("SLURM_ARRAY_TASK_COUNT", "8"),
    ]);
    assert_eq!(Shard::from_env(s).unwrap().0, shard(4, 8));
    let s = env(&[
        ("SLURM_ARRAY_TASK_ID", "4"),
        ("SLURM_ARRAY_TASK_MIN", "1"),
        ("SLURM_ARRAY_TASK_MAX", "8"),
        ("SLURM_ARRAY_TASK_COUNT", "8"),
        ("SLURM_ARRAY_TASK_STEP", "1"),
    ]);
    assert_eq!(Shard::from_env(s).unwrap().0, shard(4, 8));
    // An array with a step would leave nodes unowned: refused, naming the fix.
    let s = env(&[
        ("SLURM_ARRAY_TASK_ID", "2"),
        ("SLURM_ARRAY_TASK_MIN", "0"),
        ("SLURM_ARRAY_TASK_MAX", "6"),
        ("SLURM_ARRAY_TASK_COUNT", "4"),
        ("SLURM_ARRAY_TASK_STEP", "2"),
    ]);
    let e = Shard::from_env(s).unwrap_err().to_string();
    assert!(e.contains("contiguous") && e.contains("--array=0-3"), "{e}");
    // Kubernetes Indexed Job: 0-based index, the count from DERMA_SHARD_COUNT.
    let s = env(&[("JOB_COMPLETION_INDEX", "0"), ("DERMA_SHARD_COUNT", "4")]);
    assert_eq!(
        Shard::from_env(s).unwrap(),
        (shard(1, 4), "JOB_COMPLETION_INDEX")
    );
    let e = Shard::from_env(env(&[("JOB_COMPLETION_INDEX", "2")]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("DERMA_SHARD_COUNT"), "{e}");
    let s = env(&[("JOB_COMPLETION_INDEX", "4"), ("DERMA_SHARD_COUNT", "4")]);
    assert!(Shard::from_env(s).is_err());
    let e = Shard::from_env(env(&[("JOB_COMPLETION_INDEX", "x")]))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("JOB_COMPLETION_INDEX") && e.contains("got 'x'"),
        "{e}"
    );
    // Neither: the whole of the work. Every shard of n owns a disjoint share, together all items.
    assert_eq!(Shard::from_env(env(&[])).unwrap().0, shard(1, 1));
    for n in 1..6 {
        for i in 0..40 {
            assert_eq!((1..=n).filter(|&k| shard(k, n).owns(i)).count(), 1);
        }
    }
}

#[test]
fn a_shard_flag_is_k_of_n() {
    assert_eq!(Shard::parse("2/4").unwrap(), Shard { k: 2, n: 4 });
    for bad in ["3/2", "0/2", "x", "1/0", "1/", "/2"] {
        let e = Shard::parse(bad).unwrap_err().to_string();
        assert!(e.contains(bad) && e.contains("k/n"), "{e}");
    }
}
