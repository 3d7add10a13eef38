//! The shared GPU context (wgpu: Vulkan, Metal, DX12; Mesa's lavapipe in CI): one adapter and
//! device per process, opened on first use, and the buffer read-back every backend needs.
//! Crates build their own pipelines on it (DESIGN.md §3: one algorithm, two backends).

use std::sync::OnceLock;

/// The device, its queue and a human-readable name.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub name: String,
}

static GPU: OnceLock<Result<Gpu, String>> = OnceLock::new();

fn open() -> Result<Gpu, String> {
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        compatible_surface: None,
        apply_limit_buckets: false,
    }))
    .map_err(|e| {
        format!("no GPU adapter found ({e}); on Linux without a GPU install Mesa's lavapipe (apt-get install mesa-vulkan-drivers)")
    })?;
    let info = adapter.get_info();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("derma"),
        required_features: wgpu::Features::empty(),
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| format!("could not open the GPU device {}: {e}", info.name))?;
    Ok(Gpu {
        device,
        queue,
        name: format!("{} ({:?})", info.name, info.backend),
    })
}

/// The process's GPU, opened on first call; the error says why none could be opened.
pub fn context() -> Result<&'static Gpu, String> {
    GPU.get_or_init(open).as_ref().map_err(|e| e.clone())
}

impl Gpu {
    /// Compiles `source` (WGSL) into a compute pipeline with entry point `entry`; shader
    /// validation errors come back as text instead of a panic.
    pub fn compute_pipeline(
        &self,
        label: &str,
        source: &str,
        entry: &str,
    ) -> Result<wgpu::ComputePipeline, String> {
        self.compute_pipeline_with(label, source, entry, None)
    }

    /// As [`Gpu::compute_pipeline`], with an explicit layout (so several entry points of one
    /// shader can share one bind group even when each uses only some of its bindings).
    pub fn compute_pipeline_with(
        &self,
        label: &str,
        source: &str,
        entry: &str,
        layout: Option<&wgpu::PipelineLayout>,
    ) -> Result<wgpu::ComputePipeline, String> {
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
            return Err(format!("{label} did not compile on {}: {e}", self.name));
        }
        Ok(pipeline)
    }

    /// A bind group of whole buffers at bindings 0, 1, 2, … in the order given.
    pub fn bind_buffers(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
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
    ) -> Result<Vec<T>, String> {
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
    ) -> Result<Vec<T>, String> {
        let size = (len * std::mem::size_of::<T>()) as u64;
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buf, 0, staging, 0, size);
        self.queue.submit([enc.finish()]);
        let slice = staging.slice(..size);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| format!("reading results back: {e}"))?;
        let data = slice
            .get_mapped_range()
            .map_err(|e| format!("mapping results: {e}"))?;
        let out = bytemuck::cast_slice(&data).to_vec();
        drop(data);
        staging.unmap();
        Ok(out)
    }
}

/// For tests that need a GPU: true (skip) when `available` is false, after a note on stderr;
/// panics instead when `DERMA_REQUIRE_GPU` is set (CI runs the GPU tests on Mesa's lavapipe,
/// so a missing driver must fail there, not pass silently).
pub fn skip_test_without_gpu(available: bool) -> bool {
    if available {
        return false;
    }
    assert!(
        std::env::var("DERMA_REQUIRE_GPU").is_err(),
        "DERMA_REQUIRE_GPU is set but no GPU adapter (lavapipe: apt-get install mesa-vulkan-drivers)"
    );
    eprintln!("skipped: no GPU adapter");
    true
}
