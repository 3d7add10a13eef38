//! Chooses the backend for a run: the CPU path, or the GPU kernel when asked for.

use crate::error::Result;
use crate::run::{run_cpu, Device, Run};
use crate::tally::Tally;

/// Runs `run` on `device`.
pub fn run_on(run: &Run, device: Device, progress: &(dyn Fn(u64) + Sync)) -> Result<Tally> {
    match device {
        Device::Cpu => run_cpu(run, progress),
        Device::Gpu => crate::gpu::run_gpu(run, progress),
    }
}
