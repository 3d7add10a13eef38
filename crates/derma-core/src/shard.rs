//! Work split over the processes of a cluster job: shard k of n owns items i ≡ k − 1 (mod n),
//! from a flag ("k/n") or from the scheduler's environment (Slurm job arrays, Kubernetes Indexed Jobs).

use crate::error::{CoreError, Result};

/// A shard `k/n` (1-based k).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, 1 ≤ k ≤ n.
    pub k: usize,
    /// Number of shards.
    pub n: usize,
}

fn invalid(what: &str, expected: &str, got: String) -> CoreError {
    crate::Invalid::new(what, expected, got).into()
}

impl Shard {
    /// The whole of the work, 1/1.
    pub const WHOLE: Shard = Shard { k: 1, n: 1 };

    /// Parses "k/n".
    pub fn parse(s: &str) -> Result<Self> {
        let bad = || invalid("shard", "k/n with 1 ≤ k ≤ n", format!("'{s}'"));
        let (a, b) = s.split_once('/').ok_or_else(bad)?;
        let k: usize = a.trim().parse().map_err(|_| bad())?;
        let n: usize = b.trim().parse().map_err(|_| bad())?;
        if n == 0 || k == 0 || k > n {
            return Err(bad());
        }
        Ok(Self { k, n })
    }

    /// The shard a cluster scheduler gave this process, from its environment (`var` looks a
    /// name up, e.g. `|k| std::env::var(k).ok()`), with where it came from:
    /// - a Slurm job array: `SLURM_ARRAY_TASK_ID` within `SLURM_ARRAY_TASK_MIN` …
    ///   `SLURM_ARRAY_TASK_MAX` (step 1), n = `SLURM_ARRAY_TASK_COUNT`;
    /// - a Kubernetes Indexed Job: `JOB_COMPLETION_INDEX` (0-based), n = `DERMA_SHARD_COUNT`
    ///   (the Job's `completions`, which Kubernetes does not put in the environment);
    /// - neither: the whole of the work, 1/1.
    pub fn from_env(var: impl Fn(&str) -> Option<String>) -> Result<(Self, &'static str)> {
        let num = |name: &str| -> Result<Option<usize>> {
            match var(name) {
                None => Ok(None),
                Some(v) => v
                    .trim()
                    .parse()
                    .map(Some)
                    .map_err(|_| invalid(name, "a whole number", format!("'{v}'"))),
            }
        };
        let need = |name: &str, why: &str| -> Result<usize> {
            num(name)?.ok_or_else(|| invalid(name, &format!("a value ({why})"), "none".into()))
        };
        if let Some(id) = num("SLURM_ARRAY_TASK_ID")? {
            let why = "Slurm sets it for job arrays (sbatch --array=MIN-MAX)";
            let (min, max) = (
                need("SLURM_ARRAY_TASK_MIN", why)?,
                need("SLURM_ARRAY_TASK_MAX", why)?,
            );
            let count = need("SLURM_ARRAY_TASK_COUNT", why)?;
            let step = num("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1);
            if step != 1 || max < min || max - min + 1 != count || !(min..=max).contains(&id) {
                return Err(invalid(
                    "SLURM_ARRAY_TASK_ID",
                    &format!(
                        "a task of a contiguous array, e.g. sbatch --array=0-{} (or give the shard as k/n)",
                        count.max(1) - 1
                    ),
                    format!("task {id} of {min}-{max} (count {count}, step {step})"),
                ));
            }
            return Ok((
                Self {
                    k: id - min + 1,
                    n: count,
                },
                "SLURM_ARRAY_TASK_ID",
            ));
        }
        if let Some(index) = num("JOB_COMPLETION_INDEX")? {
            let n = need(
                "DERMA_SHARD_COUNT",
                "set it to the Indexed Job's completions (Kubernetes does not pass them)",
            )?;
            if index >= n {
                return Err(invalid(
                    "JOB_COMPLETION_INDEX",
                    &format!("an index below DERMA_SHARD_COUNT {n}"),
                    index.to_string(),
                ));
            }
            return Ok((Self { k: index + 1, n }, "JOB_COMPLETION_INDEX"));
        }
        Ok((Self::WHOLE, "no scheduler: the whole of the work"))
    }

    /// Whether item `i` belongs to this shard (i mod n = k − 1).
    pub fn owns(&self, i: usize) -> bool {
        i % self.n == self.k - 1
    }
}
