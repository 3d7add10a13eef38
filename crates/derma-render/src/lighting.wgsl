// Lighting shared by the forward pass and the lacrimal lake: the frame's bindings (group 0),
// the key light's filtered shadow and the hemisphere environment, over brdf.wgsl's terms.

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var shadow_map: texture_depth_2d;
@group(0) @binding(2) var shadow_sampler: sampler_comparison;
@group(0) @binding(3) var tex_sampler: sampler;

// Percentage-closer filtering of the key light's shadow map, 5×5 taps.
fn shadow(world: vec3<f32>, n: vec3<f32>) -> f32 {
    // Normal offset (in mm) against acne on surfaces grazing the light.
    let p = frame.light_view_proj * vec4<f32>(world + n * 0.6, 1.0);
    let ndc = p.xyz / p.w;
    let uv = vec2<f32>(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y);
    if (uv.x <= 0.0 || uv.x >= 1.0 || uv.y <= 0.0 || uv.y >= 1.0) {
        return 1.0;
    }
    let texel = frame.forward.w;
    var lit = 0.0;
    for (var j = -2; j <= 2; j++) {
        for (var i = -2; i <= 2; i++) {
            lit += textureSampleCompareLevel(shadow_map, shadow_sampler,
                uv + vec2<f32>(f32(i), f32(j)) * texel, ndc.z - 0.0015);
        }
    }
    return lit / 25.0;
}

// Hemisphere environment: sky above, ground below, blended over ±0.3 of the up component.
fn environment(d: vec3<f32>) -> vec3<f32> {
    return mix(frame.ground.rgb, frame.sky.rgb, smoothstep(-0.3, 0.3, d.y));
}

struct Lit {
    diffuse: vec3<f32>,   // irradiance-weighted diffuse term (× albedo/π·π = × albedo)
    specular: vec3<f32>,
}

// Lights `n` (shading normal) seen from `v` with the given roughness and F0: diffuse irradiance
// (radiance units, to be multiplied by the albedo) and specular radiance.
fn light_surface(world: vec3<f32>, n: vec3<f32>, ng: vec3<f32>, v: vec3<f32>, rough: f32, f0: f32) -> Lit {
    var out: Lit;
    let a = max(rough * rough, 0.002);
    let nv = max(dot(n, v), 1e-4);
    let sh = shadow(world, ng);
    for (var i = 0; i < 3; i++) {
        let l = frame.lights[i].dir.xyz;
        let e = frame.lights[i].radiance.rgb * select(1.0, sh, i == 0);
        let nl = max(dot(n, l), 0.0) * step(0.0, dot(ng, l));
        if (nl <= 0.0) {
            continue;
        }
        let h = normalize(l + v);
        let spec = ggx_d(max(dot(n, h), 0.0), a) * smith_vis(nl, nv, a) * schlick(f0, max(dot(v, h), 0.0));
        out.diffuse += e * nl * (1.0 - schlick(f0, nl)) / PI;
        out.specular += e * nl * spec;
    }
    // Ambient: the hemisphere's irradiance on n (cosine-weighted; the blend is its analytic
    // approximation) and its reflection through the split-sum fit.
    out.diffuse += environment(n) * (1.0 - f0);
    let r = reflect(-v, n);
    let ab = env_brdf(rough, nv);
    out.specular += mix(environment(r), 0.5 * (frame.sky.rgb + frame.ground.rgb), rough) * (f0 * ab.x + f90(f0) * ab.y);
    return out;
}
