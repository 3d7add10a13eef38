// derma's skin renderer, shared declarations: the frame's camera, lights and environment.

struct Light {
    dir: vec4<f32>,       // unit direction towards the light (world)
    radiance: vec4<f32>,  // rgb radiance × solid angle (irradiance at normal incidence)
}

struct Frame {
    view_proj: mat4x4<f32>,
    light_view_proj: mat4x4<f32>,
    camera: vec4<f32>,    // xyz position (mm), w = focal length in pixels
    forward: vec4<f32>,   // unit view direction, w = shadow map texel size (uv)
    viewport: vec4<f32>,  // width, height, 1/width, 1/height
    sky: vec4<f32>,       // rgb sky radiance, w = exposure
    ground: vec4<f32>,    // rgb ground radiance, w = background brightness
    right: vec4<f32>,     // camera's right axis (world)
    up: vec4<f32>,        // camera's up axis (world)
    lights: array<Light, 3>,
}


@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0);
}
