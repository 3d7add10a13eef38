// The lacrimal lake (EyeMove thesis §4.5; its constants and CPU form are lake.rs): the tear
// meniscus along the lid margins, over the globes. Pass 1 finds each globe pixel's screen-space
// distance λ to the nearest skin pixel (exact within the lake's reach Λ) and the meniscus depth
// that falls linearly with it; pass 2 tilts the globe normal by the depth's slope and returns
// the fluid's absorption (a) and its specular highlight (rgb) for the composite.

struct Lake {
    shape: vec4<f32>,   // x meniscus height at the margin (mm), y reach Λ (mm), z attenuation (1/mm), w F0
    search: vec4<f32>,  // x roughness, y most pixels searched per side, z enabled (1/0)
}

@group(1) @binding(0) var<uniform> lake: Lake;
@group(1) @binding(1) var post_tex: texture_2d<f32>;
@group(1) @binding(2) var sss_tex: texture_2d<f32>;
@group(1) @binding(3) var lake_depth: texture_2d<f32>;

fn is_eye(a: f32) -> bool {
    return abs(a - 0.5) < 0.1;
}

fn is_skin(p: vec2<i32>) -> bool {
    let size = vec2<i32>(frame.viewport.xy);
    if (any(p < vec2<i32>(0)) || any(p >= size)) {
        return false;
    }
    return textureLoad(post_tex, p, 0).a > 0.75;
}

// Pixels per mm at view depth z (perspective).
fn px_per_mm(z: f32) -> f32 {
    return frame.camera.w / max(z, 1e-3);
}

@fragment
fn fs_lake_depth(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(pos.xy);
    if (lake.search.z < 0.5 || !is_eye(textureLoad(post_tex, p, 0).a)) {
        return vec4<f32>(0.0);
    }
    let ppm = px_per_mm(textureLoad(sss_tex, p, 0).x);
    let reach = min(i32(ceil(lake.shape.y * ppm)), i32(lake.search.y));
    // Square rings outwards; a pixel on ring r is at least r away, so stop once r² exceeds the
    // best squared distance found.
    var best = 1e30;
    for (var r = 1; r <= reach; r++) {
        if (f32(r * r) >= best) {
            break;
        }
        for (var k = -r; k <= r; k++) {
            let d2 = f32(k * k + r * r);
            if (d2 >= best) {
                continue;
            }
            if (is_skin(p + vec2<i32>(k, -r)) || is_skin(p + vec2<i32>(k, r)) ||
                is_skin(p + vec2<i32>(-r, k)) || is_skin(p + vec2<i32>(r, k))) {
                best = d2;
            }
        }
    }
    let lambda = sqrt(best) / ppm;
    if (lambda >= lake.shape.y) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(lake.shape.x * (1.0 - lambda / lake.shape.y), 0.0, 0.0, 0.0);
}

// Meniscus depth at p for the slope: skin neighbours stand at the full height (lake.rs).
fn depth_at(p: vec2<i32>) -> f32 {
    if (is_skin(p)) {
        return lake.shape.x;
    }
    return textureLoad(lake_depth, p, 0).x;
}

@fragment
fn fs_lake_shade(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(pos.xy);
    let d = textureLoad(lake_depth, p, 0).x;
    if (d <= 0.0) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let post = textureLoad(post_tex, p, 0);
    let ng = normalize(post.rgb * 2.0 - 1.0);
    let z = textureLoad(sss_tex, p, 0).x;
    let mm = 1.0 / px_per_mm(z);
    // ∂depth/∂x (right) and ∂depth/∂y (up) in mm per mm, by central differences.
    let dx = (depth_at(p + vec2<i32>(1, 0)) - depth_at(p - vec2<i32>(1, 0))) / (2.0 * mm);
    let dy = -(depth_at(p + vec2<i32>(0, 1)) - depth_at(p - vec2<i32>(0, 1))) / (2.0 * mm);
    // The fluid surface rises towards the skin: a height field's normal leans down its slope,
    // away from the lid (n = (−∂x, −∂y, 1) over the globe's).
    let n = normalize(ng - dx * frame.right.xyz - dy * frame.up.xyz);
    // The pixel's point on the globe from its view depth.
    let c = (pos.xy - 0.5 * frame.viewport.xy) / frame.camera.w;
    let ray = frame.forward.xyz + c.x * frame.right.xyz - c.y * frame.up.xyz;
    let world = frame.camera.xyz + ray * z;
    let v = normalize(frame.camera.xyz - world);
    let lit = light_surface(world, n, ng, v, lake.search.x, lake.shape.w);
    // Absorption along the light's double pass through the fluid.
    return vec4<f32>(lit.specular, exp(-2.0 * lake.shape.z * d));
}
