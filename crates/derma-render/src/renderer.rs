//! The GPU renderer (orchestration of the passes in the WGSL files): the key light's shadow
//! map, the forward pass into split diffuse / direct / depth-and-profile targets, the
//! separable subsurface blur (Jimenez et al. 2015) along x then y, and the tone-mapped
//! composite, read back as an sRGB image and linear radiance.

use crate::camera::{light_view_proj, Camera, View};
use crate::error::Result;
use crate::gpu_texture::{rgba_of, RenderGpu, TexelFormat};
use crate::lighting::Lighting;
use crate::material::SkinMaps;
use crate::material::{MATERIAL_EYE, MATERIAL_OTHER, MATERIAL_SKIN};
use crate::rendered::Rendered;
use crate::scene::{Material, Part, Scene, Vertex};
use crate::sss;
use derma_core::gpu::{context, Gpu};
use derma_core::Map;

const COMMON: &str = include_str!("common.wgsl");
const FORWARD: &str = include_str!("forward.wgsl");
const BLUR: &str = include_str!("blur.wgsl");
const COMPOSITE: &str = include_str!("composite.wgsl");
const LIGHTING: &str = include_str!("lighting.wgsl");
use crate::brdf::WGSL as BRDF;
const LAKE: &str = include_str!("lake.wgsl");

/// Shadow map size (texels per side).
pub const SHADOW_SIZE: u32 = 2048;
const HDR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FrameU {
    view_proj: [[f32; 4]; 4],
    light_view_proj: [[f32; 4]; 4],
    camera: [f32; 4],
    forward: [f32; 4],
    viewport: [f32; 4],
    sky: [f32; 4],
    ground: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    lights: [[f32; 4]; 6],
}

/// The lacrimal lake's constants (lake.wgsl), from [`crate::lake`].
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct LakeU {
    shape: [f32; 4],
    search: [f32; 4],
}

impl LakeU {
    fn new(enabled: bool) -> LakeU {
        use crate::lake;
        LakeU {
            shape: [
                lake::MENISCUS_MM,
                lake::RANGE_MM,
                lake::ATTENUATION,
                lake::F0,
            ],
            search: [
                lake::ROUGHNESS,
                lake::MAX_SEARCH_PX as f32,
                if enabled { 1.0 } else { 0.0 },
                0.0,
            ],
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DrawU {
    albedo: [f32; 4],
    params: [f32; 4],
    eye: [f32; 4],
    eye_axis: [f32; 4],
    /// Eyes: the pupil's UV radius drawn, the texture's own and the iris' (derma-head's eye).
    pupil: [f32; 4],
}

/// The material of a post-scatter target's alpha byte (forward.wgsl: skin 1, eye ½).
fn material_of(alpha: u8) -> u8 {
    match alpha {
        192..=255 => MATERIAL_SKIN,
        100..=150 => MATERIAL_EYE,
        _ => MATERIAL_OTHER,
    }
}

struct GpuPart {
    vertices: wgpu::Buffer,
    count: u32,
    bind: wgpu::BindGroup,
    pass: Pass,
    casts_shadow: bool,
}

/// Which pipeline draws a part.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Pass {
    /// The forward pass's surface shader (skin, flat and textured parts).
    Surface,
    /// The forward pass's eye shader.
    Eye,
    /// The cards' pass after it: blended by coverage (weighted blended order-independent
    /// transparency, McGuire & Bavoil 2013) over what the forward pass drew.
    Blended,
}

/// A part's draw uniforms and five textures, and how it is drawn (see [`Renderer::material`]).
struct PartMaterial {
    u: DrawU,
    textures: [wgpu::Texture; 5],
    pass: Pass,
    casts_shadow: bool,
}

/// The targets of one frame size (see [`Renderer::targets`]).
struct Targets {
    size: (u32, u32),
    diffuse: wgpu::Texture,
    direct: wgpu::Texture,
    sssp: wgpu::Texture,
    post: wgpu::Texture,
    ping: wgpu::Texture,
    pong: wgpu::Texture,
    display: wgpu::Texture,
    linear: wgpu::Texture,
    depth: wgpu::Texture,
    lake_d: wgpu::Texture,
    lake_l: wgpu::Texture,
    accum: wgpu::Texture,
    reveal: wgpu::Texture,
    blur_x: wgpu::BindGroup,
    blur_y: wgpu::BindGroup,
    composite: wgpu::BindGroup,
    lake_depth: wgpu::BindGroup,
    lake_shade: wgpu::BindGroup,
}

/// The bind-group layouts of every pass (see [`Layouts::new`]).
struct Layouts {
    /// The forward and lake passes' frame group: uniforms, shadow map and samplers.
    frame: wgpu::BindGroupLayout,
    /// The shadow pass's frame group: the uniforms alone.
    shadow: wgpu::BindGroupLayout,
    /// A part's group: its uniforms and five textures.
    draw: wgpu::BindGroupLayout,
    blur: wgpu::BindGroupLayout,
    composite: wgpu::BindGroupLayout,
    lake_depth: wgpu::BindGroupLayout,
    lake_shade: wgpu::BindGroupLayout,
}

/// The shader modules: each pass's WGSL after the shared code it needs (see [`Shaders::new`]).
struct Shaders {
    forward: wgpu::ShaderModule,
    lake: wgpu::ShaderModule,
    blur: wgpu::ShaderModule,
    composite: wgpu::ShaderModule,
}

/// The render pipelines of every pass (see [`Pipelines::new`]).
struct Pipelines {
    shadow: wgpu::RenderPipeline,
    skin: wgpu::RenderPipeline,
    eye: wgpu::RenderPipeline,
    cards: wgpu::RenderPipeline,
    blur: wgpu::RenderPipeline,
    composite: wgpu::RenderPipeline,
    lake_depth: wgpu::RenderPipeline,
    lake_shade: wgpu::RenderPipeline,
}

/// The buffers, shadow map and sampler that every frame binds, whatever its size, and the
/// frame bind groups over them (see [`FrameResources::new`]).
struct FrameResources {
    lake_buf: wgpu::Buffer,
    frame_buf: wgpu::Buffer,
    shadow_tex: wgpu::Texture,
    lin_sampler: wgpu::Sampler,
    shadow_bind: wgpu::BindGroup,
    main_bind: wgpu::BindGroup,
    cdf: wgpu::Buffer,
    blur_bufs: [wgpu::Buffer; 2],
}

/// A scene on the GPU, ready to render views of it.
pub struct Renderer {
    gpu: &'static Gpu,
    parts: Vec<GpuPart>,
    layouts: Layouts,
    pipes: Pipelines,
    res: FrameResources,
    centre: glam::Vec3,
    radius: f32,
    /// The adapter's name, for reports.
    pub adapter: String,
}

fn uniform_entry(binding: u32, vis: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: vis,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A read-only storage buffer the fragment stage reads (the blur's marginal CDF).
fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn texture_entry(binding: u32, sample: wgpu::TextureSampleType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: sample,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

fn sampler_entry(binding: u32, ty: wgpu::SamplerBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(ty),
        count: None,
    }
}

const FLOAT: wgpu::TextureSampleType = wgpu::TextureSampleType::Float { filterable: true };
const VS_FS: wgpu::ShaderStages = wgpu::ShaderStages::VERTEX_FRAGMENT;

fn view(t: &wgpu::Texture) -> wgpu::TextureView {
    t.create_view(&Default::default())
}

fn layout(gpu: &Gpu, label: &str, entries: &[wgpu::BindGroupLayoutEntry]) -> wgpu::BindGroupLayout {
    gpu.device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries,
        })
}

struct PipeSpec<'a> {
    label: &'a str,
    module: &'a wgpu::ShaderModule,
    vs: &'a str,
    fs: Option<&'a str>,
    layouts: &'a [&'a wgpu::BindGroupLayout],
    targets: &'a [wgpu::TextureFormat],
    vertex: bool,
    depth: bool,
    /// The blended cards' targets: the first adds (the weighted premultiplied colour and
    /// weight), the second multiplies by 1 − α (the revealage); depth tested, not written.
    blended: bool,
}

#[allow(clippy::too_many_arguments)]
fn spec<'a>(
    label: &'a str,
    module: &'a wgpu::ShaderModule,
    vs: &'a str,
    fs: Option<&'a str>,
    layouts: &'a [&'a wgpu::BindGroupLayout],
    targets: &'a [wgpu::TextureFormat],
    vertex: bool,
    depth: bool,
) -> PipeSpec<'a> {
    PipeSpec {
        label,
        module,
        vs,
        fs,
        layouts,
        targets,
        vertex,
        depth,
        blended: false,
    }
}

/// The blend states of the blended cards' two targets ([`PipeSpec::blended`]).
fn card_blends() -> [wgpu::BlendState; 2] {
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    let reveal = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::OneMinusSrc,
        operation: wgpu::BlendOperation::Add,
    };
    [
        wgpu::BlendState {
            color: add,
            alpha: add,
        },
        wgpu::BlendState {
            color: reveal,
            alpha: reveal,
        },
    ]
}

fn pipeline(gpu: &Gpu, s: &PipeSpec) -> Result<wgpu::RenderPipeline> {
    let pl = gpu
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(s.label),
            bind_group_layouts: &s.layouts.iter().map(|l| Some(*l)).collect::<Vec<_>>(),
            immediate_size: 0,
        });
    let attrs =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2, 3 => Float32x4];
    let buffers = [Some(wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &attrs,
    })];
    let blends = card_blends();
    let targets: Vec<Option<wgpu::ColorTargetState>> = s
        .targets
        .iter()
        .enumerate()
        .map(|(k, f)| {
            Some(wgpu::ColorTargetState {
                blend: s.blended.then(|| blends[k]),
                ..(*f).into()
            })
        })
        .collect();
    Ok(gpu.validated(s.label, || {
        gpu.device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(s.label),
                layout: Some(&pl),
                vertex: wgpu::VertexState {
                    module: s.module,
                    entry_point: Some(s.vs),
                    compilation_options: Default::default(),
                    buffers: if s.vertex { &buffers } else { &[] },
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: s.depth.then(|| wgpu::DepthStencilState {
                    format: DEPTH,
                    depth_write_enabled: Some(!s.blended),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: s.fs.map(|fs| wgpu::FragmentState {
                    module: s.module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            })
    })?)
}

impl Layouts {
    /// Creates the frame, shadow, draw, blur, composite and lake layouts, in that order.
    fn new(gpu: &Gpu) -> Layouts {
        let frag = wgpu::ShaderStages::FRAGMENT;
        let frame = layout(
            gpu,
            "frame",
            &[
                uniform_entry(0, VS_FS),
                texture_entry(1, wgpu::TextureSampleType::Depth),
                sampler_entry(2, wgpu::SamplerBindingType::Comparison),
                sampler_entry(3, wgpu::SamplerBindingType::Filtering),
            ],
        );
        let shadow = layout(gpu, "shadow frame", &[uniform_entry(0, VS_FS)]);
        let draw = layout(
            gpu,
            "draw",
            &[
                uniform_entry(0, frag),
                texture_entry(1, FLOAT),
                texture_entry(2, FLOAT),
                texture_entry(3, FLOAT),
                texture_entry(4, FLOAT),
                texture_entry(5, FLOAT),
            ],
        );
        let blur = layout(
            gpu,
            "blur",
            &[
                uniform_entry(0, frag),
                uniform_entry(1, frag),
                storage_entry(2),
                texture_entry(3, FLOAT),
                texture_entry(4, FLOAT),
                sampler_entry(5, wgpu::SamplerBindingType::Filtering),
            ],
        );
        let composite = layout(
            gpu,
            "composite",
            &[
                uniform_entry(0, frag),
                texture_entry(1, FLOAT),
                texture_entry(2, FLOAT),
                texture_entry(3, FLOAT),
                texture_entry(4, FLOAT),
                texture_entry(5, FLOAT),
                texture_entry(6, FLOAT),
            ],
        );
        let lake_entries = [
            uniform_entry(0, frag),
            texture_entry(1, FLOAT),
            texture_entry(2, FLOAT),
            texture_entry(3, FLOAT),
        ];
        Layouts {
            frame,
            shadow,
            draw,
            blur,
            composite,
            lake_depth: layout(gpu, "lake depth", &lake_entries[..3]),
            lake_shade: layout(gpu, "lake shade", &lake_entries),
        }
    }
}

impl Shaders {
    /// Compiles the forward, lake, blur and composite modules, in that order.
    fn new(gpu: &Gpu) -> Result<Shaders> {
        Ok(Shaders {
            forward: gpu.shader_module(
                "forward.wgsl",
                &format!("{COMMON}\n{BRDF}\n{LIGHTING}\n{FORWARD}"),
            )?,
            lake: gpu.shader_module(
                "lake.wgsl",
                &format!("{COMMON}\n{BRDF}\n{LIGHTING}\n{LAKE}"),
            )?,
            blur: gpu.shader_module("blur.wgsl", &format!("{COMMON}\n{BLUR}"))?,
            composite: gpu.shader_module("composite.wgsl", &format!("{COMMON}\n{COMPOSITE}"))?,
        })
    }
}

/// A full-screen triangle's pipeline (no vertex buffers, no depth) with fragment shader `fs`.
fn screen_pipeline(
    gpu: &Gpu,
    label: &str,
    module: &wgpu::ShaderModule,
    fs: &str,
    layouts: &[&wgpu::BindGroupLayout],
    targets: &[wgpu::TextureFormat],
) -> Result<wgpu::RenderPipeline> {
    pipeline(
        gpu,
        &spec(
            label,
            module,
            "vs_full",
            Some(fs),
            layouts,
            targets,
            false,
            false,
        ),
    )
}

impl Pipelines {
    /// Compiles the shaders and builds every pass's pipeline on `l`'s layouts: shadow,
    /// forward skin and eye, blur, composite, lake depth and lake shade.
    fn new(gpu: &Gpu, l: &Layouts) -> Result<Pipelines> {
        let m = Shaders::new(gpu)?;
        let gtargets = [HDR, HDR, HDR, wgpu::TextureFormat::Rgba8Unorm];
        let shadow = pipeline(
            gpu,
            &spec(
                "shadow",
                &m.forward,
                "vs_shadow",
                None,
                &[&l.shadow],
                &[],
                true,
                true,
            ),
        )?;
        // The forward pass's pipelines: the parts' vertices, depth-tested, into the G-buffer.
        let forward = |label, fs| {
            let layouts = [&l.frame, &l.draw];
            pipeline(
                gpu,
                &spec(
                    label,
                    &m.forward,
                    "vs_main",
                    Some(fs),
                    &layouts,
                    &gtargets,
                    true,
                    true,
                ),
            )
        };
        let skin = forward("forward skin", "fs_skin")?;
        let eye = forward("forward eye", "fs_eye")?;
        let cards = pipeline(
            gpu,
            &PipeSpec {
                blended: true,
                ..spec(
                    "cards",
                    &m.forward,
                    "vs_main",
                    Some("fs_card"),
                    &[&l.frame, &l.draw],
                    &[HDR, HDR],
                    true,
                    true,
                )
            },
        )?;
        let blur = screen_pipeline(gpu, "blur", &m.blur, "fs_blur", &[&l.blur], &[HDR])?;
        let composite = screen_pipeline(
            gpu,
            "composite",
            &m.composite,
            "fs_composite",
            &[&l.composite],
            &[wgpu::TextureFormat::Rgba8Unorm, HDR],
        )?;
        Ok(Pipelines {
            shadow,
            skin,
            eye,
            cards,
            blur,
            composite,
            lake_depth: screen_pipeline(
                gpu,
                "lake depth",
                &m.lake,
                "fs_lake_depth",
                &[&l.frame, &l.lake_depth],
                &[HDR],
            )?,
            lake_shade: screen_pipeline(
                gpu,
                "lake shade",
                &m.lake,
                "fs_lake_shade",
                &[&l.frame, &l.lake_shade],
                &[HDR],
            )?,
        })
    }
}

impl FrameResources {
    /// Creates the lake and frame uniforms, the shadow map, the samplers, the frame bind
    /// groups on `l`'s layouts, and the blur's CDF and direction uniforms.
    fn new(gpu: &Gpu, l: &Layouts) -> FrameResources {
        let d = &gpu.device;
        let lake_buf = gpu.upload(
            "lake",
            bytemuck::bytes_of(&LakeU::new(true)),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let frame_buf = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame"),
            size: std::mem::size_of::<FrameU>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let shadow_tex = gpu.render_target("shadow map", SHADOW_SIZE, SHADOW_SIZE, DEPTH);
        let cmp_sampler = d.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let tex_sampler = gpu.sampler("textures", false);
        let lin_sampler = d.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("screen"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let shadow_bind = gpu.bind("shadow frame", &l.shadow, &[frame_buf.as_entire_binding()]);
        let main_bind = gpu.bind(
            "frame",
            &l.frame,
            &[
                frame_buf.as_entire_binding(),
                wgpu::BindingResource::TextureView(&view(&shadow_tex)),
                wgpu::BindingResource::Sampler(&cmp_sampler),
                wgpu::BindingResource::Sampler(&tex_sampler),
            ],
        );
        let cdf = gpu.upload(
            "burley marginal cdf",
            bytemuck::cast_slice(&sss::cdf_table()),
            wgpu::BufferUsages::STORAGE,
        );
        let blur_u = |dx: f32, dy: f32| {
            let u = [dx, dy, sss::TAPS as f32, sss::U_RANGE, 0.0, 0.0, 0.0, 0.0];
            gpu.upload(
                "blur",
                bytemuck::cast_slice(&u[..4]),
                wgpu::BufferUsages::UNIFORM,
            )
        };
        let blur_bufs = [blur_u(1.0, 0.0), blur_u(0.0, 1.0)];
        FrameResources {
            lake_buf,
            frame_buf,
            shadow_tex,
            lin_sampler,
            shadow_bind,
            main_bind,
            cdf,
            blur_bufs,
        }
    }
}

/// Colour attachments on `views`, each cleared to transparent and stored.
fn cleared(views: &[wgpu::TextureView]) -> Vec<Option<wgpu::RenderPassColorAttachment<'_>>> {
    views
        .iter()
        .map(|v| {
            Some(wgpu::RenderPassColorAttachment {
                view: v,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })
        })
        .collect()
}

/// Encodes one full-screen pass: `pipe` with `groups` bound in order, drawing one triangle
/// into `outs` (cleared first).
fn full_pass(
    enc: &mut wgpu::CommandEncoder,
    label: &str,
    pipe: &wgpu::RenderPipeline,
    groups: &[&wgpu::BindGroup],
    outs: &[&wgpu::Texture],
) {
    let views: Vec<wgpu::TextureView> = outs.iter().map(|t| view(t)).collect();
    let att = cleared(&views);
    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &att,
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipe);
    for (i, g) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, *g, &[]);
    }
    pass.draw(0..3, 0..1);
}

impl Renderer {
    /// Uploads `scene` to the process's GPU and builds the pipelines.
    pub fn new(scene: &Scene) -> Result<Renderer> {
        let gpu = context()?;
        let layouts = Layouts::new(gpu);
        let pipes = Pipelines::new(gpu, &layouts)?;
        let res = FrameResources::new(gpu, &layouts);
        let mut r = Renderer {
            gpu,
            parts: Vec::new(),
            layouts,
            pipes,
            res,
            centre: scene.centre,
            radius: scene.radius,
            adapter: gpu.name.clone(),
        };
        for p in &scene.parts {
            let gp = r.upload(p)?;
            r.parts.push(gp);
        }
        Ok(r)
    }

    fn tex(&self, label: &str, maps: &[&Map], format: TexelFormat) -> wgpu::Texture {
        let (px, w, h) = rgba_of(maps);
        self.gpu.texture(label, &px, w, h, format)
    }

    fn one(&self, v: [f32; 4], format: TexelFormat) -> wgpu::Texture {
        self.gpu.texture("uniform", &[v], 1, 1, format)
    }

    /// A part's five textures: its albedo, a flat normal, uniform roughness and F0, and no
    /// subsurface maps.
    fn part_textures(&self, albedo: wgpu::Texture, roughness: f32, f0: f32) -> [wgpu::Texture; 5] {
        [
            albedo,
            self.one([0.5, 0.5, 1.0, 1.0], TexelFormat::Float16),
            self.one(
                [roughness, f0 / crate::material::SPECULAR_SCALE, 0.0, 1.0],
                TexelFormat::Linear8,
            ),
            self.one([0.0; 4], TexelFormat::Srgb8),
            self.one([0.0; 4], TexelFormat::Float16),
        ]
    }

    /// [`Renderer::part_textures`] with the albedo texture of `albedo` (linear RGB maps).
    fn albedo_textures(
        &self,
        label: &str,
        albedo: &[Map; 3],
        roughness: f32,
        f0: f32,
    ) -> [wgpu::Texture; 5] {
        let albedo = self.tex(
            label,
            &[&albedo[0], &albedo[1], &albedo[2]],
            TexelFormat::Srgb8,
        );
        self.part_textures(albedo, roughness, f0)
    }

    /// Uploads part `p`: its material's textures, its uniforms and bind group, then its
    /// vertices.
    fn upload(&self, p: &Part) -> Result<GpuPart> {
        let m = self.material(&p.material);
        let bind = self.draw_bind(&p.name, &m);
        let vertices = self.gpu.upload(
            &p.name,
            bytemuck::cast_slice(&p.vertices),
            wgpu::BufferUsages::VERTEX,
        );
        Ok(GpuPart {
            vertices,
            count: p.vertices.len() as u32,
            bind,
            pass: m.pass,
            casts_shadow: m.casts_shadow,
        })
    }

    /// Uploads `m`'s uniforms and binds them with its textures on the draw layout.
    fn draw_bind(&self, name: &str, m: &PartMaterial) -> wgpu::BindGroup {
        let ubuf = self.gpu.upload(
            "draw",
            bytemuck::bytes_of(&m.u),
            wgpu::BufferUsages::UNIFORM,
        );
        let views: Vec<wgpu::TextureView> = m.textures.iter().map(view).collect();
        let mut res = vec![ubuf.as_entire_binding()];
        res.extend(views.iter().map(wgpu::BindingResource::TextureView));
        self.gpu.bind(name, &self.layouts.draw, &res)
    }

    /// The uniforms and textures (uploaded) of material `m`: the skin and the eyelash cards
    /// in [`Renderer::skin_material`] and [`Renderer::card_material`], the rest here.
    fn material(&self, m: &Material) -> PartMaterial {
        let spec_scale = crate::material::SPECULAR_SCALE;
        match m {
            Material::Skin(s) => self.skin_material(s),
            Material::Eye {
                albedo,
                centre,
                radius,
                axis,
                roughness,
                f0,
                pupil,
            } => PartMaterial {
                u: DrawU {
                    albedo: [1.0, 1.0, 1.0, 1.0],
                    params: [*roughness, *f0, 1.0, spec_scale],
                    eye: [centre.x, centre.y, centre.z, *radius],
                    eye_axis: [axis.x, axis.y, axis.z, 0.0],
                    pupil: [
                        *pupil,
                        derma_head::eye::PUPIL_UV_RADIUS,
                        derma_head::eye::IRIS_UV_RADIUS,
                        0.0,
                    ],
                },
                textures: self.albedo_textures("eye", albedo, *roughness, *f0),
                pass: Pass::Eye,
                casts_shadow: true,
            },
            Material::Textured {
                albedo,
                coverage,
                roughness,
                f0,
            } => PartMaterial {
                // A flat part (kind 2) whose albedo, roughness and F0 come from its textures, its
                // coverage (tested at ½ by forward.wgsl) the albedo texture's alpha.
                u: DrawU {
                    albedo: [1.0, 1.0, 1.0, 1.0],
                    params: [*roughness, *f0, 2.0, spec_scale],
                    eye: [0.0; 4],
                    eye_axis: [0.0; 4],
                    pupil: [0.0; 4],
                },
                textures: self.part_textures(
                    self.tex(
                        "part albedo",
                        &[&albedo[0], &albedo[1], &albedo[2]]
                            .into_iter()
                            .chain(coverage.as_deref())
                            .collect::<Vec<_>>(),
                        TexelFormat::Srgb8,
                    ),
                    *roughness,
                    *f0,
                ),
                pass: Pass::Surface,
                casts_shadow: true,
            },
            Material::Flat {
                albedo,
                roughness,
                f0,
            } => PartMaterial {
                u: DrawU {
                    albedo: [albedo.x, albedo.y, albedo.z, 0.0],
                    params: [*roughness, *f0, 2.0, spec_scale],
                    eye: [0.0; 4],
                    eye_axis: [0.0; 4],
                    pupil: [0.0; 4],
                },
                textures: self.part_textures(
                    self.one([1.0; 4], TexelFormat::Srgb8),
                    *roughness,
                    *f0,
                ),
                pass: Pass::Surface,
                casts_shadow: true,
            },
            Material::Card {
                albedo,
                coverage,
                roughness,
                f0,
            } => self.card_material(*albedo, coverage, *roughness, *f0),
        }
    }

    /// The skin's material: its base colour, normal, roughness-and-specular and (when the
    /// set has them) subsurface colour and radius maps.
    fn skin_material(&self, s: &SkinMaps) -> PartMaterial {
        let base = self.tex(
            "base colour",
            &[&s.base_color[0], &s.base_color[1], &s.base_color[2]],
            TexelFormat::Srgb8,
        );
        let normal = self.tex(
            "normal",
            &[&s.normal[0], &s.normal[1], &s.normal[2]],
            TexelFormat::Float16,
        );
        let rs = self.tex(
            "roughness, specular",
            &[&s.roughness, &s.specular],
            TexelFormat::Linear8,
        );
        let (sc, sr) = match &s.subsurface {
            Some((c, r)) => (
                self.tex("sss colour", &[&c[0], &c[1], &c[2]], TexelFormat::Srgb8),
                self.tex("sss radius", &[&r[0], &r[1], &r[2]], TexelFormat::Float16),
            ),
            None => (
                self.one([0.0; 4], TexelFormat::Srgb8),
                self.one([0.0; 4], TexelFormat::Float16),
            ),
        };
        let scatter = if s.subsurface.is_some() { 1.0 } else { 0.0 };
        PartMaterial {
            u: DrawU {
                albedo: [1.0, 1.0, 1.0, 1.0],
                params: [0.5, 0.04, 0.0, crate::material::SPECULAR_SCALE],
                eye: [0.0; 4],
                eye_axis: [0.0, 0.0, 1.0, scatter],
                pupil: [0.0; 4],
            },
            textures: [base, normal, rs, sc, sr],
            pass: Pass::Surface,
            casts_shadow: true,
        }
    }

    /// An alpha-tested card's material (kind 3): a uniform albedo with `coverage` in the
    /// texture's alpha; it casts no shadow.
    fn card_material(
        &self,
        albedo: glam::Vec3,
        coverage: &Map,
        roughness: f32,
        f0: f32,
    ) -> PartMaterial {
        let (w, h) = (coverage.width(), coverage.height());
        let px: Vec<[f32; 4]> = coverage
            .data()
            .iter()
            .map(|&c| [albedo.x, albedo.y, albedo.z, c])
            .collect();
        PartMaterial {
            u: DrawU {
                albedo: [albedo.x, albedo.y, albedo.z, 1.0],
                params: [roughness, f0, 3.0, crate::material::SPECULAR_SCALE],
                eye: [0.0; 4],
                eye_axis: [0.0; 4],
                pupil: [0.0; 4],
            },
            textures: self.part_textures(
                self.gpu.texture("card", &px, w, h, TexelFormat::Srgb8),
                roughness,
                f0,
            ),
            pass: Pass::Blended,
            casts_shadow: false,
        }
    }

    /// Replaces part `index`'s material (e.g. the skin's base colour for an animated rig frame).
    pub fn replace(&mut self, index: usize, part: &Part) -> Result<()> {
        let gp = self.upload(part)?;
        self.parts[index] = gp;
        Ok(())
    }

    /// Draws the lacrimal lake along the lid margins (on by default; off shows the bare globes).
    pub fn set_lake(&self, on: bool) {
        self.gpu
            .queue
            .write_buffer(&self.res.lake_buf, 0, bytemuck::bytes_of(&LakeU::new(on)));
    }
    /// Renders `view` under `lighting` at `w`×`h` pixels.
    pub fn render(
        &self,
        view_spec: &View,
        lighting: &Lighting,
        w: u32,
        h: u32,
    ) -> Result<Rendered> {
        let gpu = self.gpu;
        let t = self.targets(w, h);
        self.submit_frame(&t, view_spec, lighting);
        let disp = gpu.read_texture(&t.display)?;
        let lin = gpu.read_texture(&t.linear)?;
        let material = gpu
            .read_texture(&t.post)?
            .chunks_exact(4)
            .map(|p| material_of(p[3]))
            .collect();
        let linear: Vec<[f32; 3]> = lin
            .chunks_exact(8)
            .map(|c| {
                let h = |i: usize| {
                    half::f16::from_bits(u16::from_le_bytes([c[2 * i], c[2 * i + 1]])).to_f32()
                };
                [h(0), h(1), h(2)]
            })
            .collect();
        Ok(Rendered {
            width: w as usize,
            height: h as usize,
            display: disp,
            linear,
            material,
        })
    }

    /// Seconds per frame of `frames` frames of `view` at `w`×`h`, rendered into the same
    /// targets one after another as an interactive application would (no read-back), after
    /// one warm-up frame; the wall time from the first submission until the device is idle.
    pub fn time_frames(
        &self,
        view_spec: &View,
        lighting: &Lighting,
        w: u32,
        h: u32,
        frames: usize,
    ) -> Result<f64> {
        let t = self.targets(w, h);
        self.submit_frame(&t, view_spec, lighting);
        self.gpu.wait("rendering a warm-up frame")?;
        let t0 = std::time::Instant::now();
        for _ in 0..frames {
            self.submit_frame(&t, view_spec, lighting);
        }
        self.gpu.wait("rendering timed frames")?;
        Ok(t0.elapsed().as_secs_f64() / frames.max(1) as f64)
    }

    /// The render targets of one frame size, and the bind groups that read them.
    fn targets(&self, w: u32, h: u32) -> Targets {
        let gpu = self.gpu;
        let target = |label, format| gpu.render_target(label, w, h, format);
        let diffuse = target("diffuse", HDR);
        let direct = target("direct", HDR);
        let sssp = target("sss params", HDR);
        let post = target("post scatter", wgpu::TextureFormat::Rgba8Unorm);
        let ping = target("blur x", HDR);
        let pong = target("blur y", HDR);
        let display = target("display", wgpu::TextureFormat::Rgba8Unorm);
        let linear = target("linear", HDR);
        let lake_d = target("lake depth", HDR);
        let lake_l = target("lake light", HDR);
        let accum = target("cards accumulated", HDR);
        let reveal = target("cards revealage", HDR);
        let depth = target("depth", DEPTH);
        let sv = view(&sssp);
        let blur_group = |src: &wgpu::Texture, k: usize| {
            gpu.bind(
                "blur",
                &self.layouts.blur,
                &[
                    self.res.frame_buf.as_entire_binding(),
                    self.res.blur_bufs[k].as_entire_binding(),
                    self.res.cdf.as_entire_binding(),
                    wgpu::BindingResource::TextureView(&view(src)),
                    wgpu::BindingResource::TextureView(&sv),
                    wgpu::BindingResource::Sampler(&self.res.lin_sampler),
                ],
            )
        };
        let blur_x = blur_group(&diffuse, 0);
        let blur_y = blur_group(&ping, 1);
        let composite = gpu.bind(
            "composite",
            &self.layouts.composite,
            &[
                self.res.frame_buf.as_entire_binding(),
                wgpu::BindingResource::TextureView(&view(&pong)),
                wgpu::BindingResource::TextureView(&view(&direct)),
                wgpu::BindingResource::TextureView(&view(&post)),
                wgpu::BindingResource::TextureView(&view(&lake_l)),
                wgpu::BindingResource::TextureView(&view(&accum)),
                wgpu::BindingResource::TextureView(&view(&reveal)),
            ],
        );
        let (pv, lv) = (view(&post), view(&lake_d));
        let lake_in = [
            self.res.lake_buf.as_entire_binding(),
            wgpu::BindingResource::TextureView(&pv),
            wgpu::BindingResource::TextureView(&sv),
            wgpu::BindingResource::TextureView(&lv),
        ];
        let lake_depth = gpu.bind("lake depth", &self.layouts.lake_depth, &lake_in[..3]);
        let lake_shade = gpu.bind("lake shade", &self.layouts.lake_shade, &lake_in);
        Targets {
            size: (w, h),
            diffuse,
            direct,
            sssp,
            post,
            ping,
            pong,
            display,
            linear,
            depth,
            lake_d,
            lake_l,
            accum,
            reveal,
            blur_x,
            blur_y,
            composite,
            lake_depth,
            lake_shade,
        }
    }

    /// Encodes and submits one frame into `t`: shadow, forward, blur x, blur y, lake depth,
    /// lake shade, composite.
    fn submit_frame(&self, t: &Targets, view_spec: &View, lighting: &Lighting) {
        let gpu = self.gpu;
        let fu = self.frame_uniforms(t.size, view_spec, lighting);
        gpu.queue
            .write_buffer(&self.res.frame_buf, 0, bytemuck::bytes_of(&fu));
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        self.encode_shadow(&mut enc);
        self.encode_forward(&mut enc, t);
        self.encode_cards(&mut enc, t);
        self.encode_screen_passes(&mut enc, t);
        gpu.queue.submit([enc.finish()]);
    }

    /// The frame uniforms of `view_spec` at `w`×`h` under `lighting`: the camera, the key
    /// light's shadow projection, the sky and ground, and the lights in world space.
    fn frame_uniforms(&self, (w, h): (u32, u32), view_spec: &View, lighting: &Lighting) -> FrameU {
        let cam = Camera::frame(self.centre, self.radius, view_spec, w, h);
        let key = cam.to_world(lighting.lights[0].dir);
        let lvp = light_view_proj(self.centre, self.radius, key);
        let mut lights = [[0.0f32; 4]; 6];
        for (i, l) in lighting.lights.iter().enumerate() {
            let dw = cam.to_world(l.dir);
            lights[2 * i] = [dw.x, dw.y, dw.z, 0.0];
            lights[2 * i + 1] = [l.irradiance.x, l.irradiance.y, l.irradiance.z, 0.0];
        }
        FrameU {
            view_proj: cam.view_proj.to_cols_array_2d(),
            light_view_proj: lvp.to_cols_array_2d(),
            camera: [cam.eye.x, cam.eye.y, cam.eye.z, cam.focal_px],
            forward: [
                cam.forward.x,
                cam.forward.y,
                cam.forward.z,
                1.0 / SHADOW_SIZE as f32,
            ],
            viewport: [w as f32, h as f32, 1.0 / w as f32, 1.0 / h as f32],
            sky: [
                lighting.sky.x,
                lighting.sky.y,
                lighting.sky.z,
                lighting.exposure,
            ],
            ground: [lighting.ground.x, lighting.ground.y, lighting.ground.z, 1.0],
            right: cam.basis[0].extend(0.0).to_array(),
            up: cam.basis[1].extend(0.0).to_array(),
            lights,
        }
    }

    /// Encodes the shadow pass: the shadow-casting parts' depth from the key light.
    fn encode_shadow(&self, enc: &mut wgpu::CommandEncoder) {
        let sv = view(&self.res.shadow_tex);
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shadow"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &sv,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipes.shadow);
        pass.set_bind_group(0, &self.res.shadow_bind, &[]);
        for p in self.parts.iter().filter(|p| p.casts_shadow) {
            pass.set_vertex_buffer(0, p.vertices.slice(..));
            pass.draw(0..p.count, 0..1);
        }
    }

    /// Encodes the forward pass: every part into `t`'s diffuse, direct, subsurface-parameter
    /// and post-scatter targets.
    fn encode_forward(&self, enc: &mut wgpu::CommandEncoder, t: &Targets) {
        let views = [
            view(&t.diffuse),
            view(&t.direct),
            view(&t.sssp),
            view(&t.post),
        ];
        let att = cleared(&views);
        let dv = view(&t.depth);
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("forward"),
            color_attachments: &att,
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &dv,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.res.main_bind, &[]);
        for p in self.parts.iter().filter(|p| p.pass != Pass::Blended) {
            pass.set_pipeline(if p.pass == Pass::Eye {
                &self.pipes.eye
            } else {
                &self.pipes.skin
            });
            pass.set_bind_group(1, &p.bind, &[]);
            pass.set_vertex_buffer(0, p.vertices.slice(..));
            pass.draw(0..p.count, 0..1);
        }
    }

    /// Encodes the cards' pass: the blended parts, depth-tested against the forward pass's
    /// depth, into the accumulation (cleared to 0) and revealage (cleared to 1) targets.
    fn encode_cards(&self, enc: &mut wgpu::CommandEncoder, t: &Targets) {
        let views = [view(&t.accum), view(&t.reveal)];
        let clear = [wgpu::Color::TRANSPARENT, wgpu::Color::WHITE];
        let att: Vec<Option<wgpu::RenderPassColorAttachment>> = views
            .iter()
            .zip(clear)
            .map(|(v, c)| {
                Some(wgpu::RenderPassColorAttachment {
                    view: v,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(c),
                        store: wgpu::StoreOp::Store,
                    },
                })
            })
            .collect();
        let dv = view(&t.depth);
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("cards"),
            color_attachments: &att,
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &dv,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipes.cards);
        pass.set_bind_group(0, &self.res.main_bind, &[]);
        for p in self.parts.iter().filter(|p| p.pass == Pass::Blended) {
            pass.set_bind_group(1, &p.bind, &[]);
            pass.set_vertex_buffer(0, p.vertices.slice(..));
            pass.draw(0..p.count, 0..1);
        }
    }

    /// Encodes the full-screen passes on `t`: the blur along x then y, the lake's depth and
    /// shading, and the composite into the display and linear targets.
    fn encode_screen_passes(&self, enc: &mut wgpu::CommandEncoder, t: &Targets) {
        let (pipes, main) = (&self.pipes, &self.res.main_bind);
        full_pass(enc, "blur x", &pipes.blur, &[&t.blur_x], &[&t.ping]);
        full_pass(enc, "blur y", &pipes.blur, &[&t.blur_y], &[&t.pong]);
        full_pass(
            enc,
            "lake depth",
            &pipes.lake_depth,
            &[main, &t.lake_depth],
            &[&t.lake_d],
        );
        full_pass(
            enc,
            "lake shade",
            &pipes.lake_shade,
            &[main, &t.lake_shade],
            &[&t.lake_l],
        );
        full_pass(
            enc,
            "composite",
            &pipes.composite,
            &[&t.composite],
            &[&t.display, &t.linear],
        );
    }
}
