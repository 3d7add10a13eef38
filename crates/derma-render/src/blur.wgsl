// The separable subsurface blur (Jimenez et al. 2015) with Burley's normalized diffusion per
// channel (Burley 2015), the kernel weights integrated from its marginal's CDF.

struct Blur {
    dir: vec4<f32>,       // xy pixel step of this pass, z = taps per side, w = u range (units of d)
}

@group(0) @binding(0) var<uniform> blur_frame: Frame;
@group(0) @binding(1) var<uniform> blur: Blur;
@group(0) @binding(2) var<storage, read> cdf: array<f32>;  // F(u) on [0, u_max], one-sided
@group(0) @binding(3) var src: texture_2d<f32>;
@group(0) @binding(4) var sss_params: texture_2d<f32>;
@group(0) @binding(5) var lin_sampler: sampler;

// The one-sided cumulative marginal of Burley's profile at u (units of d), ½ beyond the table.
fn marginal_cdf(u: f32) -> f32 {
    let n = arrayLength(&cdf);
    let x = u / blur.dir.w * f32(n - 1u);
    if (x >= f32(n - 1u)) {
        return 0.5;
    }
    let i = u32(floor(x));
    return mix(cdf[i], cdf[i + 1u], fract(x));
}

// Tap k's offset in units of the widest channel's d: quadratic spacing, dense at the centre.
fn tap_u(k: f32) -> f32 {
    let t = k / blur.dir.z;
    return blur.dir.w * 0.5 * t * t;
}

@fragment
fn fs_blur(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(pos.xy);
    let centre = textureLoad(src, p, 0);
    let par = textureLoad(sss_params, p, 0);
    let d = par.yzw;
    let dmax = max(d.x, max(d.y, d.z));
    if (dmax <= 0.0) {
        return centre;
    }
    // Pixels per mm at this depth (perspective), and each channel's scale relative to dmax.
    let px_per_mm = blur_frame.camera.w / max(par.x, 1.0);
    let inv = dmax / d;
    let taps = blur.dir.z;
    // Centre bin [−e₀, e₀]: 2 F(e₀ / d).
    let e0 = 0.5 * tap_u(1.0);
    var acc = centre.rgb * 2.0 * vec3<f32>(marginal_cdf(e0 * inv.x), marginal_cdf(e0 * inv.y), marginal_cdf(e0 * inv.z));
    for (var k = 1.0; k <= taps; k += 1.0) {
        let lo = 0.5 * (tap_u(k - 1.0) + tap_u(k));
        var hi = 1e9;
        if (k < taps) {
            hi = 0.5 * (tap_u(k) + tap_u(k + 1.0));
        }
        let w = vec3<f32>(
            marginal_cdf(hi * inv.x) - marginal_cdf(lo * inv.x),
            marginal_cdf(hi * inv.y) - marginal_cdf(lo * inv.y),
            marginal_cdf(hi * inv.z) - marginal_cdf(lo * inv.z));
        let off = blur.dir.xy * tap_u(k) * dmax * px_per_mm;
        for (var side = -1.0; side <= 1.0; side += 2.0) {
            let uv = (pos.xy + side * off) * blur_frame.viewport.zw;
            var s = textureSampleLevel(src, lin_sampler, uv, 0.0).rgb;
            let sp = textureSampleLevel(sss_params, lin_sampler, uv, 0.0);
            // Follow the surface (Jimenez et al. 2015 §4): samples off the skin or across a
            // depth step fall back to the centre, so light does not bleed across silhouettes.
            let step_mm = abs(sp.x - par.x);
            let keep = select(0.0, 1.0, sp.y > 0.0) * clamp(1.0 - step_mm / (4.0 * dmax), 0.0, 1.0);
            s = mix(centre.rgb, s, keep);
            acc += s * w;
        }
    }
    return vec4<f32>(acc, centre.a);
}

