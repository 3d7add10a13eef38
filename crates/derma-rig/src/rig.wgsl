// derma skin appearance rig, evaluated on the GPU (Jimenez et al. 2010, eq. 6 and 7): the
// frame's hemoglobin map (dermal blood volume fraction) and its linear-sRGB colour. The same
// arithmetic, in the same order, as derma-rig's CPU path (`evaluate::hemoglobin`,
// `evaluate::color`). An engine runs it once per frame per character and samples `color` as the
// diffuse albedo (post-scattering texturing, §6).
//
// Two dispatches a frame, in this order (one bind group serves both):
//   `combine`  one thread per basis texel: g · Σ_i w_i · (bias_i, scale_i) into `combined`
//              (eq. 6's weighted sum, done once at the basis resolution as the CPU does);
//   `main`     one thread per texel: the combined maps upsampled, H, and the colour of eq. 7.
//
// Inputs (f32, rows from the top, as in the rig directory's EXRs; see rig.json):
//   h0       W × H        H_0 = H_n − μ_n                              (h0.exr)
//   melanin  W × H        C_m                                          (melanin.exr)
//   basis    layers × 2 × BH × BW: layer 0 = (μ_n, 1), layer i = (bias_i, scale_i)
//                                                        (neutral.exr, targets/NAME.exr)
//   lut      n × n × 3    linear RGB at [v][u], u = ∛(C_m/melanin_max), v = ∛(H/blood_max)
//   weights  w_0 … w_k (sum to one; w_0 is the neutral pose)
//   skin     W × H vec4<u32>: the texture set's base colour as 8-bit sRGB codes (x: R | G << 8 |
//            B << 16), then d1.rg, d1.b d2.r, d2.gb as half-float pairs (skin_response.exr), when
//            has_skin = 1 (a rig built from a set; otherwise one unused element): the colour is
//            then base + d1·x + d2·x², x = ∛H − ∛H_n, H_n the neutral's H, and not the LUT's
// Scratch: combined  BH × BW × (bias, scale).
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
    has_skin: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> weights: array<f32>;
@group(0) @binding(2) var<storage, read> h0: array<f32>;
@group(0) @binding(3) var<storage, read> melanin: array<f32>;
@group(0) @binding(4) var<storage, read> basis: array<f32>;
@group(0) @binding(5) var<storage, read> lut: array<f32>;
@group(0) @binding(6) var<storage, read> skin: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read_write> hemoglobin_out: array<f32>;
@group(0) @binding(8) var<storage, read_write> color_out: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> combined: array<vec2<f32>>;

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

// Bilinear interpolation of four basis texels: horizontal lerps first, then vertical.
fn bilinear(a0: vec2<f32>, a1: vec2<f32>, b0: vec2<f32>, b1: vec2<f32>, cx: Tap, cy: Tap) -> vec2<f32> {
    let top = a0 + (a1 - a0) * cx.t;
    let bottom = b0 + (b1 - b0) * cx.t;
    return top + (bottom - top) * cy.t;
}

// Bilinear upsampling of the combined (bias, scale).
fn upsampled(cx: Tap, cy: Tap) -> vec2<f32> {
    let r0 = cy.i0 * params.basis_width;
    let r1 = cy.i1 * params.basis_width;
    return bilinear(combined[r0 + cx.i0], combined[r0 + cx.i1], combined[r1 + cx.i0], combined[r1 + cx.i1], cx, cy);
}

// The neutral's bias μ_n (basis layer 0) upsampled as `upsampled` does the combined maps: at
// w_0 = 1 and g = 1 the two give the same bits, so a neutral frame has x = 0 exactly.
fn upsampled_neutral(cx: Tap, cy: Tap) -> f32 {
    let r0 = cy.i0 * params.basis_width;
    let r1 = cy.i1 * params.basis_width;
    let z = 0.0;
    return bilinear(vec2<f32>(basis[r0 + cx.i0], z), vec2<f32>(basis[r0 + cx.i1], z),
        vec2<f32>(basis[r1 + cx.i0], z), vec2<f32>(basis[r1 + cx.i1], z), cx, cy).x;
}

// x = ∛H − ∛H_n, exactly 0 when the two are equal.
fn cube_root_step(h: f32, hn: f32) -> f32 {
    if (h == hn) {
        return 0.0;
    }
    return pow(max(h, 0.0), 1.0 / 3.0) - pow(max(hn, 0.0), 1.0 / 3.0);
}

fn lut_at(u: u32, v: u32) -> vec3<f32> {
    let k = 3u * (v * params.lut_n + u);
    return vec3<f32>(lut[k], lut[k + 1u], lut[k + 2u]);
}

// Eq. 7: bilinear lookup at (∛(C_m/C_m,max), ∛(C_hd/C_hd,max)), nodes at the ends.
// IEC 61966-2-1's decoding of sRGB values in [0, 1] (derma_core::color::srgb_decode).
fn srgb_decode(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}

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

// Thread index of a two-dimensional dispatch (a dimension holds at most 65 535 workgroups).
fn flat_index(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.y * groups.x * 64u + id.x;
}

// Eq. 6's weighted sum at one basis texel, for both planes: g · Σ_i w_i · plane p of layer i.
@compute @workgroup_size(64)
fn combine(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let plane = params.basis_width * params.basis_height;
    let at = flat_index(id, groups);
    if (at >= plane) {
        return;
    }
    var s = vec2<f32>(0.0, 0.0);
    for (var i = 0u; i < params.layers; i++) {
        let w = weights[i];
        s += w * vec2<f32>(basis[2u * i * plane + at], basis[(2u * i + 1u) * plane + at]);
    }
    combined[at] = params.global_scale * s;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = flat_index(id, groups);
    if (k >= params.width * params.height) {
        return;
    }
    let x = k % params.width;
    let y = k / params.width;
    let cx = tap(x, params.basis_width, params.width);
    let cy = tap(y, params.basis_height, params.height);
    let c = upsampled(cx, cy);
    let h = clamp(c.x + h0[k] * c.y, 0.0, 1.0);
    hemoglobin_out[k] = h;
    if (params.has_skin == 1u) {
        let hn = clamp(upsampled_neutral(cx, cy) + h0[k] * 1.0, 0.0, 1.0);
        let s = cube_root_step(h, hn);
        let t = skin[k];
        let base = srgb_decode(unpack4x8unorm(t.x).rgb);
        let a = unpack2x16float(t.y);
        let b = unpack2x16float(t.z);
        let c = unpack2x16float(t.w);
        let d1 = vec3<f32>(a.x, a.y, b.x);
        let d2 = vec3<f32>(b.y, c.x, c.y);
        color_out[k] = vec4<f32>(clamp(base + (d1 + d2 * s) * s, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
    } else {
        color_out[k] = vec4<f32>(skin_color(melanin[k], h), 1.0);
    }
}
