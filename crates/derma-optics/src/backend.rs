//! Chooses the backend for a run: the CPU path, or the GPU kernel, as the [`Device`] says; both
//! trace the same photons with the same random streams, so they agree statistically.

use crate::cpu::run_cpu;
use crate::error::Result;
use crate::run::Run;
use crate::tally::Tally;
use derma_core::gpu::Device;
use derma_core::progress::Progress;

/// Runs `run` on `device` (resolved first: `Auto` picks a hardware GPU when there is one);
/// returns the tally and the device it ran on. `progress` advances by photons.
pub fn run_on(run: &Run, device: Device, progress: &dyn Progress) -> Result<(Tally, Device)> {
    let device = device.resolve()?;
    let tally = match device {
        #[cfg(feature = "gpu")]
        Device::Gpu => crate::gpu::run_gpu(run, progress)?,
        _ => run_cpu(run, progress)?,
    };
    Ok((tally, device))
}
