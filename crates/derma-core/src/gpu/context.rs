//! The shared GPU context of the `gpu` feature (wgpu): the process's adapter and device,
//! per-crate pipelines built once ([`GpuCell`]), uploads, submissions and read-back.

use super::GpuError;
use std::sync::OnceLock;
use wgpu::util::DeviceExt;

/// The device, its queue and a human-readable name.
pub struct Gpu {
    /// The wgpu device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Adapter name and backend, e.g. "NVIDIA H200 (Vulkan)".
    pub name: String,
    /// False for software adapters (Mesa's lavapipe, WARP), which [`Device::Auto`] passes over.
    pub hardware: bool,
}

static GPU: OnceLock<Result<Gpu, GpuError>> = OnceLock::new();

fn open() -> Result<Gpu, GpuError> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        compatible_surface: None,
        apply_limit_buckets: false,
    }))
    .map_err(|e| GpuError::NoAdapter {
        detail: e.to_string(),
    })?;
    let info = adapter.get_info();
    let name = format!("{} ({:?})", info.name, info.backend);
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("derma"),
        // 64-bit integers and floats where the adapter has them (the optics kernel's Philox
        // products, the synthesis's exact E-step).
        required_features: adapter.features()
            & (wgpu::Features::SHADER_INT64 | wgpu::Features::SHADER_F64),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| GpuError::NoDevice {
        adapter: name.clone(),
        detail: e.to_string(),
    })?;
    Ok(Gpu {
        device,
        queue,
        name,
        hardware: info.device_type != wgpu::DeviceType::Cpu,
    })
}

/// WGSL's `pack2x16float(vec2(a, b))`: `a` and `b` as IEEE half floats (round to nearest even),
/// `a` in the low 16 bits; `unpack2x16float` in a shader gives them back.
pub fn pack2x16float(a: f32, b: f32) -> u32 {
    let h = |v: f32| half::f16::from_f32(v).to_bits() as u32;
    h(a) | (h(b) << 16)
}

/// Workgroups for `threads` threads of `workgroup` each, as a two-dimensional grid (a dimension
/// holds at most 65 535 workgroups): rows of 65 535 when one row is not enough, so a shader
/// finds its thread as `gid.x + gid.y · 65 535 · workgroup`.
pub fn grid(threads: usize, workgroup: usize) -> (u32, u32) {
    let groups = threads.div_ceil(workgroup).max(1) as u32;
    let gx = groups.min(65_535);
    (gx, groups.div_ceil(gx))
}

/// The process's GPU, opened on first call; the error says why none could be opened.
pub fn context() -> Result<&'static Gpu, GpuError> {
    GPU.get_or_init(open).as_ref().map_err(Clone::clone)
}

/// GPU objects a crate builds once per process (its pipelines), on the shared context.
pub struct GpuCell<T> {
    cell: OnceLock<Result<T, GpuError>>,
}

impl<T> GpuCell<T> {
    /// An empty cell, for a `static`.
    pub const fn new() -> Self {
        Self {
            cell: OnceLock::new(),
        }
    }

    /// The context and the objects, built by `init` on first use; a failure is kept and
    /// returned to every later caller.
    pub fn get_or_init(
        &self,
        init: impl FnOnce(&'static Gpu) -> Result<T, GpuError>,
    ) -> Result<(&'static Gpu, &T), GpuError> {
        let ctx = context()?;
        let value = self
            .cell
            .get_or_init(|| init(ctx))
            .as_ref()
            .map_err(Clone::clone)?;
        Ok((ctx, value))
    }
}

impl<T> Default for GpuCell<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl Gpu {
    /// Checks that a storage buffer of `bytes` fits what this device binds and allocates (wgpu
    /// would otherwise stop the process with a validation panic): lavapipe binds 128 MiB, a
    /// data-centre GPU several GiB.
    pub fn check_storage(&self, what: impl Into<String>, bytes: u64) -> Result<(), GpuError> {
        let l = self.device.limits();
        let limit = l.max_storage_buffer_binding_size.min(l.max_buffer_size);
        if bytes > limit {
            return Err(GpuError::TooLarge {
                what: what.into(),
                bytes,
                limit,
                adapter: self.name.clone(),
            });
        }
        Ok(())
    }

    /// Runs `build` (which creates GPU objects) inside a validation error scope: a validation
    /// failure comes back as [`GpuError::Compile`] naming `label` instead of a panic.
    pub fn validated<T>(&self, label: &str, build: impl FnOnce() -> T) -> Result<T, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let value = build();
        match pollster::block_on(scope.pop()) {
            Some(e) => Err(GpuError::Compile {
                shader: label.to_string(),
                adapter: self.name.clone(),
                detail: e.to_string(),
            }),
            None => Ok(value),
        }
    }

    /// Compiles `source` (WGSL) into a compute pipeline with entry point `entry`; shader
    /// validation errors come back as [`GpuError::Compile`] instead of a panic.
    pub fn compute_pipeline(
        &self,
        label: &str,
        source: &str,
        entry: &str,
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        self.compute_pipeline_with(label, source, entry, None)
    }

    /// As [`Gpu::compute_pipeline`], with an explicit layout (so several entry points of one
    /// shader can share one bind group even when each uses only some of its bindings; see
    /// [`Gpu::entry_points`]).
    fn compute_pipeline_with(
        &self,
        label: &str,
        source: &str,
        entry: &str,
        layout: Option<&wgpu::PipelineLayout>,
    ) -> Result<wgpu::ComputePipeline, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Compile {
                shader: label.to_string(),
                adapter: self.name.clone(),
                detail: e.to_string(),
            });
        }
        Ok(pipeline)
    }

    /// One bind group layout for several entry points of a shader, and its pipeline layout
    /// ([`Gpu::entry_points`]):
    /// binding 0 a uniform buffer, then `read_only` read-only storage buffers, then
    /// `read_write` read-write ones (each entry point may use only some of them).
    fn storage_layout(
        &self,
        label: &str,
        read_only: u32,
        read_write: u32,
    ) -> (wgpu::BindGroupLayout, wgpu::PipelineLayout) {
        let entry = |binding: u32, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty,
            count: None,
        };
        let buffer = |ty| wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let storage = |read_only| buffer(wgpu::BufferBindingType::Storage { read_only });
        let mut entries = vec![entry(0, buffer(wgpu::BufferBindingType::Uniform))];
        entries.extend((1..=read_only).map(|b| entry(b, storage(true))));
        entries.extend((read_only + 1..=read_only + read_write).map(|b| entry(b, storage(false))));
        let layout = self
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries: &entries,
            });
        let pipeline_layout = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        (layout, pipeline_layout)
    }

    /// Compiles the entry points `entries` of one shader against one shared layout
    /// (binding 0 uniform, `read_only` then `read_write` storage buffers): the layout they
    /// share, so one bind group serves them all, and the pipelines in the order given.
    pub fn entry_points<const N: usize>(
        &self,
        label: &str,
        source: &str,
        read_only: u32,
        read_write: u32,
        entries: [&str; N],
    ) -> Result<(wgpu::BindGroupLayout, [wgpu::ComputePipeline; N]), GpuError> {
        let (layout, pipeline_layout) = self.storage_layout(label, read_only, read_write);
        let pipelines = entries
            .iter()
            .map(|e| {
                self.compute_pipeline_with(
                    &format!("{label} ({e})"),
                    source,
                    e,
                    Some(&pipeline_layout),
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        let pipelines: [wgpu::ComputePipeline; N] = pipelines
            .try_into()
            .unwrap_or_else(|_| unreachable!("one pipeline per entry point"));
        Ok((layout, pipelines))
    }

    /// A buffer holding `bytes`.
    pub fn upload(&self, label: &str, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage,
            })
    }

    /// Submits one compute pass per (pipeline, workgroups), in order, all bound to `group`, as
    /// one submission; its index, for [`Gpu::wait_for`].
    pub fn submit_passes(
        &self,
        group: &wgpu::BindGroup,
        passes: &[(&wgpu::ComputePipeline, (u32, u32))],
    ) -> wgpu::SubmissionIndex {
        let mut enc = self.device.create_command_encoder(&Default::default());
        for &(pipe, (x, y)) in passes {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipe);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
        self.queue.submit([enc.finish()])
    }

    /// A bind group of whole buffers at bindings 0, 1, 2, … in the order given.
    pub fn bind_buffers(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let res: Vec<wgpu::BindingResource> =
            buffers.iter().map(|b| b.as_entire_binding()).collect();
        self.bind(label, layout, &res)
    }

    /// A bind group of any resources (buffers, texture views, samplers) at bindings 0, 1, 2, …
    /// in the order given.
    pub fn bind(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        res: &[wgpu::BindingResource],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = res
            .iter()
            .enumerate()
            .map(|(i, r)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: r.clone(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &entries,
        })
    }

    /// Copies the first `len` 32-bit words of `buf` (which needs COPY_SRC) back to the host.
    pub fn read_back<T: bytemuck::Pod>(
        &self,
        buf: &wgpu::Buffer,
        len: usize,
    ) -> Result<Vec<T>, GpuError> {
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read back"),
            size: (len * std::mem::size_of::<T>()) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.read_back_with(buf, &staging, len)
    }

    /// As [`Gpu::read_back`], through a staging buffer the caller keeps (MAP_READ | COPY_DST,
    /// at least `len` elements), for read-backs on a hot path.
    pub fn read_back_with<T: bytemuck::Pod>(
        &self,
        buf: &wgpu::Buffer,
        staging: &wgpu::Buffer,
        len: usize,
    ) -> Result<Vec<T>, GpuError> {
        let size = (len * std::mem::size_of::<T>()) as u64;
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buf, 0, staging, 0, size);
        self.queue.submit([enc.finish()]);
        let slice = staging.slice(..size);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.wait("reading results back")?;
        let data = slice.get_mapped_range().map_err(|e| GpuError::Device {
            during: "mapping results",
            detail: e.to_string(),
        })?;
        let out = bytemuck::cast_slice(&data).to_vec();
        drop(data);
        staging.unmap();
        Ok(out)
    }

    /// Waits until the device has finished the work submitted so far.
    pub fn wait(&self, during: &'static str) -> Result<(), GpuError> {
        self.wait_until(None, during)
    }

    /// Waits until the device has finished submission `index` (and what came before it),
    /// leaving later submissions running: how a host keeps the next dispatch queued.
    pub fn wait_for(
        &self,
        index: wgpu::SubmissionIndex,
        during: &'static str,
    ) -> Result<(), GpuError> {
        self.wait_until(Some(index), during)
    }

    fn wait_until(
        &self,
        submission_index: Option<wgpu::SubmissionIndex>,
        during: &'static str,
    ) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index,
                timeout: None,
            })
            .map(|_| ())
            .map_err(|e| GpuError::Device {
                during,
                detail: e.to_string(),
            })
    }
}
