// The E-step of Shen et al. §3.3 (Kwatra et al. 2005, §3) in two bands on the GPU: each texel
// becomes the weighted mean of its covering windows' low bands plus the high band of the one of
// least cost, bit for bit as e_step.rs's (see optimize.rs and bands.rs for why).
//
// Exactness. The CPU finds the window of least cost (the first among equals), then sums
// ω·L + ω·H in f64 over the covering windows in a fixed order (rows of windows, then columns),
// L the window's low band and H the chosen window's high band, and rounds (acc / Σω) to f32.
// Here: ω, L and H are f32, so each product is exact in f64 (48 significant bits) and a fused
// multiply-add rounds exactly as the CPU's separate multiply and add; f64 additions are
// correctly rounded on Vulkan, in the same order.
// The f64 division is not (Vulkan allows 2.5 ulp), so the quotient is formed by integer long
// division and rounded twice, to f64 then f32, both to nearest even, as Rust's `as f32` does.
// The codes come from the quantiser's boundaries (exemplar.rs, `boundaries`), compared as
// integer keys: no floating-point division there either.

struct Params {
    width: u32,
    height: u32,
    channels: u32,
    // Windows per row of windows.
    cols: u32,
    // Texels to blend (the `quotients` check: pairs to divide).
    count: u32,
    // Where the exemplars' low bands start in `exemplars` (after two words per exemplar).
    values_at: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> p: Params;
// Per window: exemplar, texel of its match's top-left corner in that exemplar (y · width + x),
// the window's weight (f32 bits), its cost.
@group(0) @binding(1) var<storage, read> windows: array<vec4<u32>>;
// Which windows cover each column and row: width + 1 column offsets, height + 1 row offsets
// (indices of the first pair of each list in this array), then (window, offset in it) pairs.
@group(0) @binding(2) var<storage, read> cover: array<u32>;
// Per exemplar (width, first word of its low band), then the low bands (f32 bits, interleaved).
@group(0) @binding(3) var<storage, read> exemplars: array<u32>;
// The high bands, word k at `exemplars`' word values_at + k.
@group(0) @binding(4) var<storage, read> high: array<u32>;
// The quantiser's boundaries: 256 order keys per channel (entry 0 unused).
@group(0) @binding(5) var<storage, read> bounds: array<u32>;
@group(0) @binding(6) var<storage, read_write> values: array<u32>;
@group(0) @binding(7) var<storage, read_write> sources: array<u32>;
@group(0) @binding(8) var<storage, read_write> source_exemplars: array<u32>;
@group(0) @binding(9) var<storage, read_write> codes: array<u32>;

const WORKGROUP: u32 = 64u;
const MANTISSA: u64 = 0xffffffffffffflu;
const HIDDEN: u64 = 0x10000000000000lu;

fn thread_index(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * 65535u * WORKGROUP;
}

// Bits of the f32 that Rust's `(a / b) as f32` gives, for a finite and b > 0, both normal or
// zero (every sum here is: a nonzero sum of products of f32s is a multiple of 2⁻²⁹⁸, far above
// f64's smallest normal 2⁻¹⁰²²).
fn quotient_f32(a: f64, b: f64) -> u32 {
    let ab = bitcast<u64>(a);
    let bb = bitcast<u64>(b);
    let sign = u32(ab >> 63u) << 31u;
    let ea = i32((ab >> 52u) & 0x7fflu);
    if (ea == 0) {
        return sign;
    }
    let eb = i32((bb >> 52u) & 0x7fflu);
    var ma = (ab & MANTISSA) | HIDDEN;
    let mb = (bb & MANTISSA) | HIDDEN;
    var e = ea - eb;
    if (ma < mb) {
        ma = ma << 1u;
        e -= 1;
    }
    // 56 quotient bits, the first 1: q / 2⁵⁵ · 2ᵉ, remainder r.
    var q = 0lu;
    var r = ma;
    for (var i = 0u; i < 56u; i++) {
        q = q << 1u;
        if (r >= mb) {
            r -= mb;
            q |= 1lu;
        }
        r = r << 1u;
    }
    // To f64: 53 bits, to nearest, ties to even (3 guard bits, the remainder as sticky bit).
    var m = q >> 3u;
    let guard = q & 7lu;
    if (guard > 4lu || (guard == 4lu && (r != 0lu || (m & 1lu) == 1lu))) {
        m += 1lu;
    }
    if (m == HIDDEN << 1u) {
        m = HIDDEN;
        e += 1;
    }
    // To f32: the value is m · 2^(e − 52); 24 bits where normal, fewer below 2⁻¹²⁶.
    var shift = 29u;
    if (e < -126) {
        shift = 29u + u32(-126 - e);
    }
    if (shift > 54u) {
        return sign;
    }
    var kept = m >> shift;
    let rest = m & ((1lu << shift) - 1lu);
    let half = 1lu << (shift - 1u);
    if (rest > half || (rest == half && (kept & 1lu) == 1lu)) {
        kept += 1lu;
    }
    if (e < -126) {
        // Subnormal, or the least normal where rounding carried into the exponent field.
        return sign | u32(kept);
    }
    if (kept == 1lu << 24u) {
        kept = 1lu << 23u;
        e += 1;
    }
    if (e > 127) {
        return sign | 0x7f800000u;
    }
    return sign | (u32(e + 127) << 23u) | (u32(kept) & 0x7fffffu);
}

// exemplar.rs's `order_key`.
fn order_key(bits: u32) -> u32 {
    if ((bits >> 31u) == 1u) {
        return ~bits;
    }
    return bits | 0x80000000u;
}

// The code of a value of channel k: how many of its boundaries lie at or below the value's key
// (the boundaries rise with j, so a binary search).
fn code_of(bits: u32, k: u32) -> u32 {
    let key = order_key(bits);
    var n = 0u;
    for (var step = 128u; step > 0u; step = step >> 1u) {
        if (bounds[k * 256u + n + step] <= key) {
            n += step;
        }
    }
    return n;
}

// The low band of channel k of window `win`'s match at offset (ox, oy).
fn match_low(win: vec4<u32>, ox: u32, oy: u32, k: u32) -> f32 {
    let ew = exemplars[2u * win.x];
    let s = win.y + oy * ew + ox;
    return bitcast<f32>(exemplars[exemplars[2u * win.x + 1u] + s * p.channels + k]);
}

@compute @workgroup_size(64)
fn blend(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = thread_index(gid);
    if (t >= p.count) {
        return;
    }
    let x = t % p.width;
    let y = t / p.width;
    let x0 = cover[x];
    let x1 = cover[x + 1u];
    let y0 = cover[p.width + 1u + y];
    let y1 = cover[p.width + 2u + y];
    // The chosen window: the least cost, the first in order among equals.
    var best_cost = 0xffffffffu;
    var best_ex = 0u;
    var best_src = 0xffffffffu;
    var wsum = f64(0.0);
    for (var j = y0; j < y1; j += 2u) {
        for (var i = x0; i < x1; i += 2u) {
            let win = windows[cover[j] * p.cols + cover[i]];
            wsum += f64(bitcast<f32>(win.z));
            if (best_src == 0xffffffffu || win.w < best_cost) {
                best_cost = win.w;
                best_ex = win.x;
                best_src = win.y + cover[j + 1u] * exemplars[2u * win.x] + cover[i + 1u];
            }
        }
    }
    let first_high = exemplars[2u * best_ex + 1u] - p.values_at + best_src * p.channels;
    for (var k = 0u; k < p.channels; k++) {
        let h = f64(bitcast<f32>(high[first_high + k]));
        var acc = f64(0.0);
        for (var j = y0; j < y1; j += 2u) {
            for (var i = x0; i < x1; i += 2u) {
                let win = windows[cover[j] * p.cols + cover[i]];
                let wk = f64(bitcast<f32>(win.z));
                acc += wk * f64(match_low(win, cover[i + 1u], cover[j + 1u], k));
                acc += wk * h;
            }
        }
        let bits = quotient_f32(acc, wsum);
        values[t * p.channels + k] = bits;
        codes[t * p.channels + k] = code_of(bits, k);
    }
    sources[t] = best_src;
    source_exemplars[t] = best_ex;
}

// Check of `quotient_f32` and `code_of` (tests): pair i is (a, b) as the f64 bits (lo, hi,
// lo, hi) of windows[i]; values[i] gets the quotient's f32 bits, codes[i] its code in channel 0.
@compute @workgroup_size(64)
fn quotients(@builtin(global_invocation_id) gid: vec3<u32>) {
    let t = thread_index(gid);
    if (t >= p.count) {
        return;
    }
    let w = windows[t];
    let a = bitcast<f64>((u64(w.y) << 32u) | u64(w.x));
    let b = bitcast<f64>((u64(w.w) << 32u) | u64(w.z));
    values[t] = quotient_f32(a, b);
    codes[t] = code_of(values[t], 0u);
}
