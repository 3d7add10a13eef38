// The composite: scattered diffuse × post-scatter albedo + the rest (through the lacrimal lake
// where there is one), ACES tone mapping, sRGB.

@group(0) @binding(0) var<uniform> comp_frame: Frame;
@group(0) @binding(1) var scattered: texture_2d<f32>;
@group(0) @binding(2) var direct_light: texture_2d<f32>;
@group(0) @binding(3) var post_scatter: texture_2d<f32>;
@group(0) @binding(4) var lake_light: texture_2d<f32>;  // rgb lake highlight, a its absorption
@group(0) @binding(5) var cards_accum: texture_2d<f32>;  // forward.wgsl's fs_card: Σ w α c, Σ w α
@group(0) @binding(6) var cards_reveal: texture_2d<f32>; // r: Π (1 − α) of the cards

// Narkowicz 2015, "ACES filmic tone mapping curve": a fit of the ACES RRT + ODT.
fn aces(x: vec3<f32>) -> vec3<f32> {
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn srgb(x: vec3<f32>) -> vec3<f32> {
    let lo = x * 12.92;
    let hi = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, x <= vec3<f32>(0.0031308));
}

struct CompOut {
    @location(0) display: vec4<f32>,  // tone-mapped sRGB
    @location(1) linear: vec4<f32>,   // scene-referred linear radiance (EXR)
}

@fragment
fn fs_composite(@builtin(position) pos: vec4<f32>) -> CompOut {
    let p = vec2<i32>(pos.xy);
    let dl = textureLoad(direct_light, p, 0);
    let reveal = textureLoad(cards_reveal, p, 0).r;
    var o: CompOut;
    if (dl.a <= 0.0 && reveal >= 1.0) {
        // Background: a soft vertical gradient.
        let t = pos.y * comp_frame.viewport.w;
        let bg = comp_frame.ground.w * mix(vec3<f32>(0.06, 0.065, 0.075), vec3<f32>(0.02, 0.02, 0.025), t);
        o.display = vec4<f32>(bg, 1.0);
        o.linear = vec4<f32>(0.0);
        return o;
    }
    var rgb = vec3<f32>(0.0);  // under cards, the background counts as black light (as the CPU frame)
    if (dl.a > 0.0) {
        let lk = textureLoad(lake_light, p, 0);
        // The post-scatter albedo, stored as its square root (forward.wgsl).
        let post = textureLoad(post_scatter, p, 0).rgb;
        rgb = textureLoad(scattered, p, 0).rgb * post * post + dl.rgb * lk.a + lk.rgb;
    }
    if (reveal < 1.0) {
        // The cards over it (McGuire & Bavoil 2013 eq. 6): their weighted mean radiance,
        // covering 1 − Π (1 − α); exact for one layer.
        let acc = textureLoad(cards_accum, p, 0);
        rgb = rgb * reveal + acc.rgb / max(acc.a, 1e-6) * (1.0 - reveal);
    }
    o.linear = vec4<f32>(rgb, 1.0);
    o.display = vec4<f32>(srgb(aces(rgb * comp_frame.sky.w)), 1.0);
    return o;
}
