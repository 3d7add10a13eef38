// The microfacet terms every shader of the renderer shares, mirrored by brdf.rs (a GPU test
// holds the two together): GGX (Walter et al. 2007), height-correlated Smith visibility
// (Heitz 2014), Schlick's Fresnel towards Frostbite's f90 and Karis 2014's split-sum
// environment fit.

const PI: f32 = 3.14159265;

// GGX / Trowbridge–Reitz distribution (Walter et al. 2007) with α = roughness².
fn ggx_d(nh: f32, a: f32) -> f32 {
    let a2 = a * a;
    let d = nh * nh * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

// Height-correlated Smith visibility G₂ / (4 n·l n·v) (Heitz 2014, eq. 99).
fn smith_vis(nl: f32, nv: f32, a: f32) -> f32 {
    let a2 = a * a;
    let gv = nl * sqrt(nv * nv * (1.0 - a2) + a2);
    let gl = nv * sqrt(nl * nl * (1.0 - a2) + a2);
    return 0.5 / max(gv + gl, 1e-5);
}

// Schlick's Fresnel. The cosine is clamped: a dot product of unit vectors can round past 1, and
// WGSL's pow of a negative base is undefined (NaN on lavapipe; one such pixel spread by the
// blur into a 20-pixel black square).
fn schlick(f0: f32, vh: f32) -> f32 {
    return f0 + (f90(f0) - f0) * pow(clamp(1.0 - vh, 0.0, 1.0), 5.0);
}

// Reflectance at grazing incidence: 1 for every real dielectric (F0 ≥ 2 %), to 0 below it
// (Lagarde & de Rousiers 2014, "Moving Frostbite to PBR": f90 = saturate(50 F0)).
fn f90(f0: f32) -> f32 {
    return clamp(50.0 * f0, 0.0, 1.0);
}

// Karis 2014 ("Physically based shading on mobile"): analytic fit of the split-sum
// environment BRDF, returning the F0 scale and bias.
fn env_brdf(rough: f32, nv: f32) -> vec2<f32> {
    let c0 = vec4<f32>(-1.0, -0.0275, -0.572, 0.022);
    let c1 = vec4<f32>(1.0, 0.0425, 1.04, -0.04);
    let r = rough * c0 + c1;
    let a004 = min(r.x * r.x, exp2(-9.28 * nv)) * r.x + r.y;
    return vec2<f32>(-1.04, 1.04) * a004 + r.zw;
}
