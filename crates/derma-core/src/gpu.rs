//! The [`Device`] choice every command offers (`--device auto|cpu|gpu`) and typed
//! [`GpuError`]s, in every build; with the `gpu` feature, the shared GPU context too (wgpu:
//! Vulkan, Metal, DX12; Mesa's lavapipe in CI): one adapter and device per process opened on
//! first use, per-crate pipelines built once ([`GpuCell`]) and the buffer read-back every
//! backend needs. Crates build their own pipelines on it (one algorithm, two backends: the CPU
//! path is the reference, the WGSL path differs only in dispatch). Without the feature (the
//! default build, which compiles without wgpu) `auto` is the CPU and `gpu` a clear error.

use serde::{Deserialize, Serialize};

#[cfg(feature = "gpu")]
mod context;
#[cfg(feature = "gpu")]
pub use context::{context, grid, pack2x16float, Gpu, GpuCell};

/// Whether this build has the GPU backends (the `gpu` cargo feature).
pub const BUILT: bool = cfg!(feature = "gpu");

/// Where a job runs: the user's choice, the same on every command.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Device {
    /// A hardware GPU when one can be opened, else the CPU (a software adapter such as Mesa's
    /// lavapipe is slower than the CPU path, so `auto` does not pick it).
    #[default]
    Auto,
    /// The CPU (rayon): the reference path, always available.
    Cpu,
    /// The GPU adapter wgpu opens, hardware or software; an error when there is none.
    Gpu,
}

impl Device {
    /// Every choice, in the order `--help` lists them.
    pub const ALL: [Device; 3] = [Device::Auto, Device::Cpu, Device::Gpu];

    /// The choice as written on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Device::Auto => "auto",
            Device::Cpu => "cpu",
            Device::Gpu => "gpu",
        }
    }

    /// The device a job runs on, `Cpu` or `Gpu`: `Auto` becomes `Gpu` when a hardware GPU
    /// opens and `Cpu` otherwise; `Gpu` opens the GPU now, so a missing one is reported before
    /// any work.
    pub fn resolve(self) -> Result<Device, GpuError> {
        match self {
            Device::Cpu => Ok(Device::Cpu),
            Device::Gpu => open().map(|_| Device::Gpu),
            Device::Auto => Ok(match open() {
                Ok(true) => Device::Gpu,
                _ => Device::Cpu,
            }),
        }
    }
}

/// Opens the process's GPU; true for a hardware adapter.
#[cfg(feature = "gpu")]
fn open() -> Result<bool, GpuError> {
    context().map(|g| g.hardware)
}

/// A build without the `gpu` feature has no GPU to open.
#[cfg(not(feature = "gpu"))]
fn open() -> Result<bool, GpuError> {
    Err(GpuError::NotBuilt)
}

impl std::fmt::Display for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Device {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Device::ALL
            .into_iter()
            .find(|d| d.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| format!("device '{s}': expected auto, cpu or gpu"))
    }
}

/// Why the GPU could not be used.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum GpuError {
    /// This build has no GPU backends.
    #[error(
        "this derma was built without GPU support: choose the CPU device (or auto), or rebuild \
         derma with its cargo feature `gpu`"
    )]
    NotBuilt,
    /// wgpu found no adapter at all.
    #[error("no GPU adapter found ({detail}); on Linux without a GPU install Mesa's lavapipe (apt-get install mesa-vulkan-drivers)")]
    NoAdapter {
        /// wgpu's reason.
        detail: String,
    },
    /// The adapter exists but its device could not be opened.
    #[error("could not open the GPU device {adapter}: {detail}")]
    NoDevice {
        /// The adapter's name and backend.
        adapter: String,
        /// wgpu's reason.
        detail: String,
    },
    /// A shader failed validation on this adapter.
    #[error("{shader} did not compile on {adapter}: {detail}")]
    Compile {
        /// Which shader (and entry point).
        shader: String,
        /// The adapter's name and backend.
        adapter: String,
        /// The validation error.
        detail: String,
    },
    /// The device failed while work was running or results were read back.
    #[error("the GPU failed while {during}: {detail}")]
    Device {
        /// What derma was doing.
        during: &'static str,
        /// wgpu's reason.
        detail: String,
    },
    /// A buffer is larger than the adapter binds (or allocates) at once.
    #[error(
        "{what} needs {bytes} bytes on the GPU; {adapter} binds at most {limit} bytes per \
         storage buffer — use a smaller size or the CPU device"
    )]
    TooLarge {
        /// The buffer, in words ("the rig's colour output at 4096×4096").
        what: String,
        /// Its size.
        bytes: u64,
        /// The adapter's limit.
        limit: u64,
        /// The adapter's name and backend.
        adapter: String,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_build_parses_the_choice_and_resolves_the_cpu() {
        for d in Device::ALL {
            assert_eq!(d.name().parse::<Device>(), Ok(d));
        }
        assert!("tpu"
            .parse::<Device>()
            .unwrap_err()
            .contains("auto, cpu or gpu"));
        assert_eq!(Device::Cpu.resolve(), Ok(Device::Cpu));
    }

    /// Without the `gpu` feature (the default build; the test command runs this once so):
    /// `auto` is the CPU and `gpu` an error that says how to get it.
    #[cfg(not(feature = "gpu"))]
    #[test]
    fn a_build_without_the_feature_runs_auto_on_the_cpu_and_refuses_gpu() {
        assert_eq!(Device::Auto.resolve(), Ok(Device::Cpu));
        let e = Device::Gpu.resolve().unwrap_err();
        assert_eq!(e, GpuError::NotBuilt);
        assert!(e.to_string().contains("cargo feature `gpu`"), "{e}");
    }
}
