// derma skin appearance rig, evaluated on the GPU (Jimenez et al. 2010, eq. 6 and 7): one
// thread per texel writes the frame's hemoglobin map (dermal blood volume fraction) and its
// linear-sRGB colour. The same arithmetic, in the same order, as derma-rig's CPU path
// (`evaluate::hemoglobin`, `evaluate::color`). An engine can run it once per frame per
// character and sample `color` as the diffuse albedo (post-scattering texturing, §6).
//
// Inputs (f32, rows from the top, as in the rig directory's EXRs; see rig.json):
//   h0       W × H        H_0 = H_n − μ_n                              (h0.exr)
//   melanin  W × H        C_m                                          (melanin.exr)
//   basis    layers × 2 × BH × BW: layer 0 = (μ_n, 1), layer i = (bias_i, scale_i)
//                                                        (neutral.exr, targets/NAME.exr)
//   lut      n × n × 3    linear RGB at [v][u], u = ∛(C_m/melanin_max), v = ∛(H/blood_max)
//   weights  w_0 … w_k (sum to one; w_0 is the neutral pose)
// Basis maps are upsampled bilinearly with clamp to edge and texel centres at half-integers.

struct Params {
    width: u32,
    height: u32,
    basis_width: u32,
    basis_height: u32,
    layers: u32,
    lut_n: u32,
    global_scale: f32,
    melanin_max: f32,
    blood_max: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> weights: array<f32>;
@group(0) @binding(2) var<storage, read> h0: array<f32>;
@group(0) @binding(3) var<storage, read> melanin: array<f32>;
@group(0) @binding(4) var<storage, read> basis: array<f32>;
@group(0) @binding(5) var<storage, read> lut: array<f32>;
@group(0) @binding(6) var<storage, read_write> hemoglobin_out: array<f32>;
@group(0) @binding(7) var<storage, read_write> color_out: array<vec4<f32>>;

struct Tap {
    i0: u32,
    i1: u32,
    t: f32,
};

// Source taps of output coordinate `x` when `src` texels are stretched over `dst`.
fn tap(x: u32, src: u32, dst: u32) -> Tap {
    let f = clamp((f32(x) + 0.5) * f32(src) / f32(dst) - 0.5, 0.0, f32(src - 1u));
    let i0 = min(u32(floor(f)), src - 1u);
    return Tap(i0, min(i0 + 1u, src - 1u), f - f32(i0));
}

// g · Σ_i w_i · plane p of layer i at basis texel (x, y): the weighted sum of eq. 6.
fn combined(p: u32, x: u32, y: u32) -> f32 {
    let plane = params.basis_width * params.basis_height;
    let at = y * params.basis_width + x;
    var s = 0.0;
    for (var i = 0u; i < params.layers; i++) {
        s += weights[i] * basis[(2u * i + p) * plane + at];
    }
    return params.global_scale * s;
}

// Bilinear upsampling of the combined plane p: horizontal lerps first, then vertical.
fn upsampled(p: u32, cx: Tap, cy: Tap) -> f32 {
    let a0 = combined(p, cx.i0, cy.i0);
    let a1 = combined(p, cx.i1, cy.i0);
    let b0 = combined(p, cx.i0, cy.i1);
    let b1 = combined(p, cx.i1, cy.i1);
    let top = a0 + (a1 - a0) * cx.t;
    let bottom = b0 + (b1 - b0) * cx.t;
    return top + (bottom - top) * cy.t;
}

fn lut_at(u: u32, v: u32) -> vec3<f32> {
    let k = 3u * (v * params.lut_n + u);
    return vec3<f32>(lut[k], lut[k + 1u], lut[k + 2u]);
}

// Eq. 7: bilinear lookup at (∛(C_m/C_m,max), ∛(C_hd/C_hd,max)), nodes at the ends.
fn skin_color(c_m: f32, c_hd: f32) -> vec3<f32> {
    let n = params.lut_n;
    let u = min(pow(max(c_m, 0.0) / params.melanin_max, 1.0 / 3.0), 1.0) * f32(n - 1u);
    let v = min(pow(max(c_hd, 0.0) / params.blood_max, 1.0 / 3.0), 1.0) * f32(n - 1u);
    let i = min(u32(u), n - 2u);
    let j = min(u32(v), n - 2u);
    let fx = u - f32(i);
    let fy = v - f32(j);
    let top = mix(lut_at(i, j), lut_at(i + 1u, j), fx);
    let bottom = mix(lut_at(i, j + 1u), lut_at(i + 1u, j + 1u), fx);
    return mix(top, bottom, fy);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    // Two-dimensional dispatch (a dimension holds at most 65 535 workgroups).
    let k = id.y * groups.x * 64u + id.x;
    if (k >= params.width * params.height) {
        return;
    }
    let x = k % params.width;
    let y = k / params.width;
    let cx = tap(x, params.basis_width, params.width);
    let cy = tap(y, params.basis_height, params.height);
    let bias = upsampled(0u, cx, cy);
    let scale = upsampled(1u, cx, cy);
    let h = clamp(bias + h0[k] * scale, 0.0, 1.0);
    hemoglobin_out[k] = h;
    color_out[k] = vec4<f32>(skin_color(melanin[k], h), 1.0);
}
