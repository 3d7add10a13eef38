// Photon transport in a layered specimen on the GPU: the WGSL port of transport.rs (thesis
// §4.4–4.5; weights + Russian roulette as MCML, Wang, Jacques & Zheng 1995), same Philox stream.
//
// Work: every workgroup serves one wavelength λ = workgroup % nλ, so its photons share their
// layer data. Within a dispatch (photons offset … offset + count, offset a multiple of nλ) the
// photons of λ are k = offset + λ + nλ·m, m = 0, 1, …; lane r of the λ's `lanes` lanes runs
// m = r, r + lanes, … Any such split traces every photon once with its own Philox stream.
// Tallies: each photon's values are rounded to 64-bit fixed point (2^-24 units) and added with
// integer atomics, first into the workgroup's tallies and then, once per workgroup, into the
// global ones (pairs of u32). Integer adds commute, so results depend neither on scheduling nor
// on the number of threads: the host sizes dispatches to the device.

struct Params {
    seed_lo: u32, seed_hi: u32, offset_lo: u32, offset_hi: u32,
    count: u32, lanes: u32, n_lambda: u32, n_layers: u32,
    incidence: u32, surface: u32, sigma: f32, bottom: u32,
    bottom_value: f32, n_above: f32, brdf_ti: u32, brdf_to: u32,
    brdf_phi: u32, channels: u32, profile_bins: u32, profile_dmax: f32,
}

@group(0) @binding(0) var<uniform> P: Params;
// Per (wavelength, layer): z_top, z_bot, mut, mua/mut, 1/mut, g, n (7 floats).
@group(0) @binding(1) var<storage, read> layers: array<f32>;
// Per wavelength: BRDF channel weights.
@group(0) @binding(2) var<storage, read> chan: array<f32>;
// Fixed-point tallies (lo, hi pairs):
// [0, 8·nλ): per wavelength sum and sum of squares of (Rs, Rd, T, A);
// then per wavelength and layer the absorbed weight (the host splits it among absorbers by the
// layer's shares); then roulette, then BRDF bins·channels, then profile.
@group(0) @binding(3) var<storage, read_write> acc: array<atomic<u32>>;
// Photon counts: per wavelength, then per θi bin.
@group(0) @binding(4) var<storage, read_write> counts: array<atomic<u32>>;

const TAU: f32 = 6.283185307179586;
const ROULETTE_WEIGHT: f32 = 1e-4;
const ROULETTE_CHANCE: f32 = 0.1;
const FACING_TRIES: u32 = 8u;
const WORKGROUP: u32 = 64u;
const MAX_LAYERS: u32 = 8u;  // derma_optics::MAX_LAYERS (Stack::validate refuses more)
// Workgroup tallies: sums 0–3, squares 4–7, absorbed per layer 8…, roulette last.
const WG_SLOTS: u32 = 9u + MAX_LAYERS;
var<workgroup> wg_acc: array<atomic<u32>, 2u * WG_SLOTS>;
var<workgroup> wg_launched: atomic<u32>;
// A photon's absorbed weight per layer, one column per thread (no per-thread array in memory).
var<workgroup> wg_absorbed: array<f32, MAX_LAYERS * WORKGROUP>;

// ---- Philox4x32-10 (Salmon et al. 2011). The 32×32 → 64-bit product from 16-bit halves; where
// the device has 64-bit integers the host swaps in the native product (same bits).
// mulhilo begin
fn mulhilo(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu; let a1 = a >> 16u;
    let b0 = b & 0xffffu; let b1 = b >> 16u;
    let p00 = a0 * b0; let p01 = a0 * b1; let p10 = a1 * b0; let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    let lo = (p00 & 0xffffu) | (mid << 16u);
    let hi = p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
    return vec2<u32>(lo, hi);
}
// mulhilo end

fn philox(c_in: vec4<u32>, k_in: vec2<u32>) -> vec4<u32> {
    var c = c_in; var k = k_in;
    for (var r = 0u; r < 10u; r++) {
        let p0 = mulhilo(0xD2511F53u, c.x);
        let p1 = mulhilo(0xCD9E8D57u, c.z);
        c = vec4<u32>(p1.y ^ c.y ^ k.x, p1.x, p0.y ^ c.w ^ k.y, p0.x);
        k = k + vec2<u32>(0x9E3779B9u, 0xBB67AE85u);
    }
    return c;
}

struct Rng { ctr: vec4<u32>, buf: vec4<u32>, pos: u32 }
var<private> rng: Rng;
var<private> key: vec2<u32>;

fn next_u32() -> u32 {
    if (rng.pos == 4u) {
        rng.buf = philox(rng.ctr, key);
        rng.ctr.w = rng.ctr.w + 1u;
        rng.pos = 0u;
    }
    let w = rng.buf[rng.pos];
    rng.pos = rng.pos + 1u;
    return w;
}

fn rand01() -> f32 {
    return f32(next_u32() >> 8u) * (1.0 / 16777216.0);
}

// ---- Fixed-point accumulation: round(v · 2^24) as a 64-bit two's complement integer (lo, hi).
fn to_fixed(v: f32) -> vec2<u32> {
    let s = round(v * 16777216.0);
    let hi = floor(s / 4294967296.0);
    let lo = u32(clamp(s - hi * 4294967296.0, 0.0, 4294967295.0));
    return vec2<u32>(lo, bitcast<u32>(i32(hi)));
}

// The high word to add once the low word f.x has been added to `old`: f.y plus the carry.
fn high_word(old: u32, f: vec2<u32>) -> u32 {
    return f.y + select(0u, 1u, old > 0xffffffffu - f.x);
}

// Adds the pair f to global slot `slot`.
fn add_pair(slot: u32, f: vec2<u32>) {
    if (f.x == 0u && f.y == 0u) { return; }
    let h = high_word(atomicAdd(&acc[2u * slot], f.x), f);
    if (h != 0u) { atomicAdd(&acc[2u * slot + 1u], h); }
}

fn add_fixed(slot: u32, v: f32) {
    if (v != 0.0) { add_pair(slot, to_fixed(v)); }
}

// Adds v to the workgroup's slot `slot`.
fn add_wg(slot: u32, v: f32) {
    if (v == 0.0) { return; }
    let f = to_fixed(v);
    let h = high_word(atomicAdd(&wg_acc[2u * slot], f.x), f);
    if (h != 0u) { atomicAdd(&wg_acc[2u * slot + 1u], h); }
}

// ---- Layer data.
fn L(lambda: u32, layer: u32, f: u32) -> f32 {
    return layers[(lambda * P.n_layers + layer) * 7u + f];  // 7: LAYER_FLOATS in gpu.rs
}

fn fresnel(cos_i_in: f32, n1: f32, n2: f32) -> f32 {
    let cos_i = clamp(cos_i_in, 0.0, 1.0);
    let sin_t = n1 / n2 * sqrt(max(0.0, 1.0 - cos_i * cos_i));
    if (sin_t >= 1.0) { return 1.0; }
    let cos_t = sqrt(1.0 - sin_t * sin_t);
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i);
    return 0.5 * (rs * rs + rp * rp);
}

fn fresnel_event(u: vec3<f32>, m: vec3<f32>, n1: f32, n2: f32, xi: f32) -> vec3<f32> {
    let cos_i = -dot(u, m);
    let f = fresnel(cos_i, n1, n2);
    if (xi < f) { return u + 2.0 * cos_i * m; }
    let eta = n1 / n2;
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    let cos_t = sqrt(max(0.0, 1.0 - sin2_t));
    return eta * u + (eta * cos_i - cos_t) * m;
}

fn tr_cos_zenith(rho: f32, sigma: f32) -> f32 {
    let s2 = sigma * sigma;
    var cos2 = rho;
    if (abs(s2 - 1.0) >= 1e-6) {
        let s4 = s2 * s2;
        cos2 = (s2 / sqrt(s4 - s4 * rho + rho) - 1.0) / (s2 - 1.0);
    }
    return sqrt(clamp(cos2, 0.0, 1.0));
}

// ---- The Smith microsurface (microsurface.rs): GGX Λ, visible normals (Heitz 2018), the
// dielectric random walk over uniform heights (Heitz et al. 2016). Same draws as the CPU.
const WALK_EVENTS: u32 = 256u;
const MIN_DRAW: f32 = 5.9604645e-8;  // 2^-24: a zero draw taken as the smallest non-zero one

fn smith_lambda(c: f32, a: f32) -> f32 {
    if (c >= 1.0) { return 0.0; }
    if (c <= 0.0) { return 3.0e38; }
    let tan2 = (1.0 - c * c) / (c * c);
    return 0.5 * (-1.0 + sqrt(1.0 + a * a * tan2));
}

fn visible_normal(wi: vec3<f32>, a: f32, u1: f32, u2: f32) -> vec3<f32> {
    let vh = normalize(vec3<f32>(a * wi.x, a * wi.y, wi.z));
    let len2 = vh.x * vh.x + vh.y * vh.y;
    var t1 = vec3<f32>(1.0, 0.0, 0.0);
    if (len2 > 0.0) { t1 = vec3<f32>(-vh.y, vh.x, 0.0) / sqrt(len2); }
    let t2 = cross(vh, t1);
    let r = sqrt(u1);
    let phi = TAU * u2;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * r * sin(phi);
    let p3 = sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2));
    let nh = p1 * t1 + p2 * t2 + p3 * vh;
    return normalize(vec3<f32>(a * nh.x, a * nh.y, max(nh.z, 1e-9)));
}

// `d` local to the starting side (d.z < 0); returns the exit direction in that frame.
fn smith_walk(d: vec3<f32>, n1: f32, n2: f32, a: f32) -> vec3<f32> {
    var dir = d;
    var flip = false;
    var c1 = 1.0;
    var na = n1;
    var nb = n2;
    for (var e = 0u; e < WALK_EVENTS; e++) {
        var z = dir.z;
        if (flip) { z = -dir.z; }
        let u = rand01();
        if (z > 0.0) {
            let lam = smith_lambda(z, a);
            if (1.0 - u <= pow(c1, lam)) { return dir; }
            c1 = c1 / exp(log(1.0 - u) / lam);
        } else {
            let lam = smith_lambda(-z, a);
            c1 = c1 * exp(log(max(u, MIN_DRAW)) / (1.0 + lam));
        }
        let u1 = rand01();
        let u2 = rand01();
        var m = visible_normal(vec3<f32>(-dir.x, -dir.y, -z), a, u1, u2);
        if (flip) { m.z = -m.z; }
        let wi = -dir;
        let ci = max(dot(wi, m), 0.0);
        if (rand01() < fresnel(ci, na, nb)) {
            dir = normalize(-wi + 2.0 * ci * m);
        } else {
            let eta = na / nb;
            let sin2_t = eta * eta * (1.0 - ci * ci);
            let ct = sqrt(max(0.0, 1.0 - sin2_t));
            dir = normalize(eta * dir + (eta * ci - ct) * m);
            flip = !flip;
            c1 = 1.0 - c1;
            let t = na; na = nb; nb = t;
        }
    }
    if (flip) { return vec3<f32>(0.0, 0.0, -1.0); }
    return vec3<f32>(0.0, 0.0, 1.0);
}

fn top_surface(u: vec3<f32>, n1: f32, n2: f32, side: f32) -> vec3<f32> {
    if (P.surface == 2u) {
        let e = smith_walk(vec3<f32>(u.x, u.y, u.z * side), n1, n2, P.sigma);
        return vec3<f32>(e.x, e.y, e.z * side);
    }
    var m = vec3<f32>(0.0, 0.0, side);
    if (P.surface == 1u) {
        var found = false;
        for (var t = 0u; t < FACING_TRIES; t++) {
            let c = tr_cos_zenith(rand01(), P.sigma);
            let phi = TAU * rand01();
            let s = sqrt(max(0.0, 1.0 - c * c));
            let cand = vec3<f32>(s * cos(phi), s * sin(phi), side * c);
            if (dot(u, cand) < 0.0) { m = cand; found = true; break; }
        }
    }
    return normalize(fresnel_event(u, m, n1, n2, rand01()));
}

fn hg_cos(g: f32, xi: f32) -> f32 {
    if (abs(g) < 1e-6) { return 2.0 * xi - 1.0; }
    let t = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi);
    return clamp((1.0 + g * g - t * t) / (2.0 * g), -1.0, 1.0);
}

fn spin(u: vec3<f32>, ct: f32, phi: f32) -> vec3<f32> {
    let st = sqrt(max(0.0, 1.0 - ct * ct));
    let sp = sin(phi); let cp = cos(phi);
    if (abs(u.z) > 0.99999) {
        return vec3<f32>(st * cp, st * sp, ct * sign(u.z));
    }
    let temp = sqrt(1.0 - u.z * u.z);
    return normalize(vec3<f32>(
        st * (u.x * u.z * cp - u.y * sp) / temp + u.x * ct,
        st * (u.y * u.z * cp + u.x * sp) / temp + u.y * ct,
        -st * cp * temp + u.z * ct));
}

fn slot_absorbed() -> u32 { return 8u * P.n_lambda; }
fn slot_roulette() -> u32 { return slot_absorbed() + P.n_lambda * P.n_layers; }
fn slot_brdf() -> u32 { return slot_roulette() + 1u; }
fn slot_profile() -> u32 { return slot_brdf() + P.brdf_ti * P.brdf_to * P.brdf_phi * P.channels; }

fn record_exit(lambda: u32, ti: u32, pos: vec3<f32>, u: vec3<f32>, w: f32, diffuse: bool) {
    if (P.brdf_ti > 0u) {
        let theta = acos(clamp(-u.z, -1.0, 1.0));
        let to = min(u32(theta / 1.5707963267948966 * f32(P.brdf_to)), P.brdf_to - 1u);
        let phi = abs(atan2(u.y, u.x));
        let p = min(u32(phi / 3.141592653589793 * f32(P.brdf_phi)), P.brdf_phi - 1u);
        let base = ((ti * P.brdf_to + to) * P.brdf_phi + p) * P.channels;
        for (var c = 0u; c < P.channels; c++) {
            add_fixed(slot_brdf() + base + c, w * chan[lambda * P.channels + c]);
        }
    }
    if (diffuse && P.profile_bins > 0u) {
        let r = length(pos.xy);
        let b = u32(r / P.profile_dmax * f32(P.profile_bins));
        if (b < P.profile_bins) {
            add_fixed(slot_profile() + lambda * P.profile_bins + b, w);
        }
    }
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    key = vec2<u32>(P.seed_lo, P.seed_hi);
    let lambda = wid.x % P.n_lambda;
    let lane = (wid.x / P.n_lambda) * WORKGROUP + li;
    let nl = P.n_layers;
    // Photons of this wavelength in the dispatch: k = λ + nλ·m < count.
    var of_lambda = 0u;
    if (lambda < P.count) { of_lambda = (P.count - lambda - 1u) / P.n_lambda + 1u; }
    var launched = 0u;
    for (var m = lane; m < of_lambda; m += P.lanes) {
        // 64-bit photon index offset + j.
        let j = lambda + P.n_lambda * m;
        let lo = P.offset_lo + j;
        var hi = P.offset_hi;
        if (lo < j) { hi = hi + 1u; }
        rng.ctr = vec4<u32>(lo, hi, 0x4f50u, 0u);
        rng.pos = 4u;
        launched = launched + 1u;
        var out = array<f32, 4>(0.0, 0.0, 0.0, 0.0);
        for (var l = 0u; l < nl; l++) { wg_absorbed[l * WORKGROUP + li] = 0.0; }
        var roulette = 0.0;

        var sin_i = 0.0;
        var cos_i = 1.0;
        if (P.incidence == 1u) {
            sin_i = rand01();
            cos_i = sqrt(1.0 - sin_i * sin_i);
        }
        var ti = 0u;
        if (P.brdf_ti > 0u) {
            ti = min(u32(asin(sin_i) / 1.5707963267948966 * f32(P.brdf_ti)), P.brdf_ti - 1u);
            atomicAdd(&counts[P.n_lambda + ti], 1u);
        }
        var u = vec3<f32>(-sin_i, 0.0, cos_i);
        var pos = vec3<f32>(0.0, 0.0, 0.0);
        var w = 1.0;
        let n0 = L(lambda, 0u, 6u);
        if (P.surface == 0u) {
            let f = fresnel(cos_i, P.n_above, n0);
            out[0] = f;
            if (f > 0.0) { record_exit(lambda, ti, pos, vec3<f32>(u.x, u.y, -u.z), f, false); }
            w = 1.0 - f;
            let sin_t = P.n_above / n0 * sin_i;
            u = vec3<f32>(-sin_t, 0.0, sqrt(1.0 - sin_t * sin_t));
        } else {
            let v = top_surface(u, P.n_above, n0, -1.0);
            if (v.z <= 0.0) {
                out[0] = 1.0;
                record_exit(lambda, ti, pos, v, 1.0, false);
                w = 0.0;
            }
            u = v;
        }

        var layer = 0u;
        var s_left = 0.0;
        var steps = 0u;
        while (w > 0.0) {
            steps = steps + 1u;
            if (steps > 100000000u) { roulette = roulette - w; w = 0.0; break; }
            if (s_left <= 0.0) { s_left = -log(1.0 - rand01()); }
            let mu_t = L(lambda, layer, 2u);
            var dist = 3.0e38;
            if (u.z > 0.0) { dist = (L(lambda, layer, 1u) - pos.z) / u.z; }
            else if (u.z < 0.0) { dist = (L(lambda, layer, 0u) - pos.z) / u.z; }
            if (mu_t * dist <= s_left) {
                pos = vec3<f32>(pos.xy + u.xy * dist, pos.z);
                s_left = s_left - mu_t * dist;
                let up = u.z < 0.0;
                if (up) { pos.z = L(lambda, layer, 0u); } else { pos.z = L(lambda, layer, 1u); }
                if (up && layer == 0u) {
                    let v = top_surface(u, L(lambda, 0u, 6u), P.n_above, 1.0);
                    if (v.z < 0.0) {
                        out[1] = out[1] + w;
                        record_exit(lambda, ti, pos, v, w, true);
                        w = 0.0;
                    } else { u = v; }
                } else if (!up && layer == nl - 1u) {
                    if (P.bottom == 0u) {
                        let v = fresnel_event(u, vec3<f32>(0.0, 0.0, -1.0), L(lambda, layer, 6u), P.bottom_value, rand01());
                        if (v.z > 0.0) { out[2] = out[2] + w; w = 0.0; } else { u = v; }
                    } else {
                        out[2] = out[2] + w * (1.0 - P.bottom_value);
                        w = w * P.bottom_value;
                        let c = sqrt(rand01());
                        let phi = TAU * rand01();
                        let s = sqrt(max(0.0, 1.0 - c * c));
                        u = vec3<f32>(s * cos(phi), s * sin(phi), -c);
                    }
                } else {
                    var next = layer + 1u;
                    if (up) { next = layer - 1u; }
                    let n1 = L(lambda, layer, 6u);
                    let n2 = L(lambda, next, 6u);
                    if (n1 == n2) {
                        layer = next;
                    } else {
                        var side = -1.0;
                        if (up) { side = 1.0; }
                        let v = fresnel_event(u, vec3<f32>(0.0, 0.0, side), n1, n2, rand01());
                        if ((v.z < 0.0) == up) { layer = next; }
                        u = v;
                    }
                }
            } else {
                let d = s_left * L(lambda, layer, 4u);
                s_left = 0.0;
                pos = pos + u * d;
                let dw = w * L(lambda, layer, 3u);
                if (dw > 0.0) {
                    wg_absorbed[layer * WORKGROUP + li] = wg_absorbed[layer * WORKGROUP + li] + dw;
                    out[3] = out[3] + dw;
                    w = w - dw;
                }
                let ct = hg_cos(L(lambda, layer, 5u), rand01());
                u = spin(u, ct, TAU * rand01());
                if (w < ROULETTE_WEIGHT) {
                    if (rand01() < ROULETTE_CHANCE) {
                        roulette = roulette + w * (1.0 / ROULETTE_CHANCE - 1.0);
                        w = w / ROULETTE_CHANCE;
                    } else {
                        roulette = roulette - w;
                        w = 0.0;
                    }
                }
            }
        }
        for (var k = 0u; k < 4u; k++) {
            add_wg(k, out[k]);
            add_wg(4u + k, out[k] * out[k]);
        }
        for (var l = 0u; l < nl; l++) {
            add_wg(8u + l, wg_absorbed[l * WORKGROUP + li]);
        }
        add_wg(8u + MAX_LAYERS, roulette);
    }
    atomicAdd(&wg_launched, launched);
    // Once per workgroup: its tallies into the global ones.
    workgroupBarrier();
    if (li < WG_SLOTS) {
        let f = vec2<u32>(atomicLoad(&wg_acc[2u * li]), atomicLoad(&wg_acc[2u * li + 1u]));
        if (li < 8u) {
            add_pair(lambda * 8u + li, f);
        } else if (li < 8u + nl) {
            add_pair(slot_absorbed() + lambda * nl + li - 8u, f);
        } else if (li == 8u + MAX_LAYERS) {
            add_pair(slot_roulette(), f);
        }
    } else if (li == WG_SLOTS) {
        let n = atomicLoad(&wg_launched);
        if (n > 0u) { atomicAdd(&counts[lambda], n); }
    }
}
