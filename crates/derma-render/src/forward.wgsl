// The shadow pass from the key light and the forward pass, which splits skin's diffuse light
// (to be scattered by blur.wgsl) from everything else.

struct Draw {
    albedo: vec4<f32>,    // rgb flat albedo (linear) for non-textured parts, w = textured (1/0)
    params: vec4<f32>,    // x perceptual roughness, y F0, z kind, w specular scale (F0 per unit)
    eye: vec4<f32>,       // eye centre (mm), w = globe radius
    eye_axis: vec4<f32>,  // optical axis (unit), w = scatter (1: skin's subsurface maps apply)
    pupil: vec4<f32>,     // eyes: x the pupil's UV radius drawn, y the texture's own, z the iris'
}

// Pupil dilation through texture coordinates (derma-head's eye::dilated_uv): the UV to read
// for the globe's `uv`, the pupil scaled to its new edge and the iris stretched to the limbus.
fn dilated_uv(uv: vec2<f32>) -> vec2<f32> {
    let d = uv - vec2<f32>(0.5);
    let r = length(d);
    let p = draw.pupil.x;
    let own = draw.pupil.y;
    let iris = draw.pupil.z;
    if (r <= 0.0 || r >= iris || p <= 0.0) {
        return uv;
    }
    var rt = own + (r - p) / (iris - p) * (iris - own);
    if (r < p) {
        rt = r / p * own;
    }
    return vec2<f32>(0.5) + d * (rt / r);
}

const KIND_SKIN: f32 = 0.0;
const KIND_EYE: f32 = 1.0;
const KIND_FLAT: f32 = 2.0;
const KIND_CARD: f32 = 3.0;


@group(1) @binding(0) var<uniform> draw: Draw;
@group(1) @binding(1) var base_color: texture_2d<f32>;
@group(1) @binding(2) var normal_map: texture_2d<f32>;
@group(1) @binding(3) var rough_spec: texture_2d<f32>;
@group(1) @binding(4) var sss_color: texture_2d<f32>;
@group(1) @binding(5) var sss_radius: texture_2d<f32>;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) tangent: vec4<f32>,
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) tangent: vec4<f32>,
}

@vertex
fn vs_shadow(v: VertexIn) -> @builtin(position) vec4<f32> {
    return frame.light_view_proj * vec4<f32>(v.position, 1.0);
}

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var o: VertexOut;
    o.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    o.world = v.position;
    o.normal = v.normal;
    o.uv = v.uv;
    o.tangent = v.tangent;
    return o;
}

// Texture coordinates: derma's UVs have v up (OpenGL); textures are stored top row first.
fn tex_uv(uv: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(uv.x, 1.0 - uv.y);
}

// post.a marks the material for the lacrimal lake (lake.wgsl): the skin mesh, the globes,
// anything else (lashes, teeth, tongue; the background stays 0).
const MATERIAL_SKIN: f32 = 1.0;
const MATERIAL_EYE: f32 = 0.5;

fn skin_marker() -> f32 {
    return select(0.0, MATERIAL_SKIN, draw.params.z == KIND_SKIN);
}

struct GOut {
    @location(0) diffuse: vec4<f32>,  // skin: colourless diffuse light, to be scattered
    @location(1) direct: vec4<f32>,   // everything not scattered; a = coverage
    @location(2) sss: vec4<f32>,      // x view depth (mm), yzw Burley shape d per channel (mm)
    @location(3) post: vec4<f32>,     // skin: √albedo, squared and applied after scattering; eyes: normal; a material
}

fn shading_normal(in: VertexOut, ng: vec3<f32>, textured: bool) -> vec3<f32> {
    if (!textured) {
        return ng;
    }
    let t0 = in.tangent.xyz - ng * dot(ng, in.tangent.xyz);
    if (dot(t0, t0) < 1e-12) {
        return ng;
    }
    let t = normalize(t0);
    let b = cross(ng, t) * in.tangent.w;
    let m = textureSample(normal_map, tex_sampler, tex_uv(in.uv)).xyz * 2.0 - 1.0;
    return normalize(t * m.x + b * m.y + ng * m.z);
}

// Burley's s(A) (Christensen & Burley 2015 eq. 6): ℓ = d s(A).
fn burley_s(a: vec3<f32>) -> vec3<f32> {
    let e = a - vec3<f32>(0.8);
    return vec3<f32>(1.9) - a + 3.5 * e * e;
}

fn view_depth(world: vec3<f32>) -> f32 {
    return dot(world - frame.camera.xyz, frame.forward.xyz);
}

// A blended card fragment's weight (McGuire & Bavoil 2013, "Weighted Blended Order-Independent
// Transparency", eq. 9, view depth in metres), scaled by 1/100 so a few overlapping layers stay
// within a half-float target: nearer layers count more where cards overlap.
fn card_weight(depth_mm: f32, alpha: f32) -> f32 {
    let z = depth_mm * 1e-3;
    return alpha * clamp(0.1 / (1e-5 + pow(z / 5.0, 2.0) + pow(z / 200.0, 6.0)), 1e-4, 30.0);
}

struct CardOut {
    @location(0) accum: vec4<f32>,   // Σ w α c (premultiplied radiance), Σ w α
    @location(1) reveal: vec4<f32>,  // r α: the target keeps Π (1 − α)
}

// Cards (lashes, brows, stubble), blended by their coverage over what the forward pass drew
// (composite.wgsl resolves them): no dither, no alpha test.
@fragment
fn fs_card(in: VertexOut, @builtin(front_facing) front: bool) -> CardOut {
    var o: CardOut;
    let v = normalize(frame.camera.xyz - in.world);
    var ng = normalize(in.normal);
    if (!front) {
        ng = -ng;
    }
    let c = textureSample(base_color, tex_sampler, tex_uv(in.uv));
    let rs = textureSample(rough_spec, tex_sampler, tex_uv(in.uv));
    let alpha = clamp(c.a, 0.0, 1.0);
    if (alpha <= 0.0) {
        discard;
    }
    let lit = light_surface(in.world, ng, ng, v, rs.r, rs.g * draw.params.w);
    let rgb = lit.diffuse * c.rgb + lit.specular;
    let w = card_weight(view_depth(in.world), alpha);
    o.accum = vec4<f32>(rgb * w, w);
    o.reveal = vec4<f32>(alpha, 0.0, 0.0, 0.0);
    return o;
}

@fragment
fn fs_skin(in: VertexOut, @builtin(front_facing) front: bool) -> GOut {
    var o: GOut;
    let v = normalize(frame.camera.xyz - in.world);
    var ng = normalize(in.normal);
    if (!front) {
        ng = -ng;
    }
    let textured = draw.albedo.w > 0.5;
    var albedo = draw.albedo.rgb;
    var rough = draw.params.x;
    var f0 = draw.params.y;
    var coverage = 1.0;
    if (textured) {
        let c = textureSample(base_color, tex_sampler, tex_uv(in.uv));
        albedo = c.rgb;
        coverage = c.a;
        let rs = textureSample(rough_spec, tex_sampler, tex_uv(in.uv));
        rough = rs.r;
        f0 = rs.g * draw.params.w;
    }
    // A textured part's voids (the alpha of `derma photo teeth`'s texture between the teeth).
    if (textured && draw.params.z == KIND_FLAT && coverage < 0.5) {
        discard;
    }
    let n = shading_normal(in, ng, textured && draw.params.z == KIND_SKIN);
    let lit = light_surface(in.world, n, ng, v, rough, f0);
    o.sss = vec4<f32>(view_depth(in.world), 0.0, 0.0, 0.0);
    if (draw.eye_axis.w > 0.5) {
        // Skin with subsurface maps: the diffuse light is scattered by the blur passes.
        let sa = textureSample(sss_color, tex_sampler, tex_uv(in.uv)).rgb;
        let mfp = textureSample(sss_radius, tex_sampler, tex_uv(in.uv)).rgb;
        let d = max(mfp / burley_s(clamp(sa, vec3<f32>(0.0), vec3<f32>(1.0))), vec3<f32>(1e-4));
        // Post-scatter texturing (Jimenez et al. 2010 §6): colourless light is scattered and the
        // set's colour multiplied after, once — its maps already hold the colour the scattering
        // made (the skin's diffuse reflectance, not a surface pigment seen twice).
        // The 8-bit target holds √albedo (a gamma of 2: dark skin's blue keeps its precision);
        // composite.wgsl squares it.
        o.diffuse = vec4<f32>(lit.diffuse, 1.0);
        o.post = vec4<f32>(sqrt(max(albedo, vec3<f32>(0.0))), skin_marker());
        o.sss = vec4<f32>(o.sss.x, d);
        o.direct = vec4<f32>(lit.specular, 1.0);
    } else {
        o.direct = vec4<f32>(lit.diffuse * albedo + lit.specular, 1.0);
        o.post = vec4<f32>(0.0, 0.0, 0.0, skin_marker());
    }
    return o;
}

// Ray–sphere: distance along unit `d` from `o` to the first hit of the sphere (c, r), or −1.
fn hit_sphere(o: vec3<f32>, d: vec3<f32>, c: vec3<f32>, r: f32) -> f32 {
    let oc = o - c;
    let b = dot(oc, d);
    let disc = b * b - (dot(oc, oc) - r * r);
    if (disc < 0.0) {
        return -1.0;
    }
    return -b - sqrt(disc);
}

// Eye geometry (derma-eyes' globe, after Le Grand's schematic eye): the cornea is a 7.8 mm
// sphere whose apex stands 1.1 mm proud of the globe; the iris plane lies 3.6 mm behind the apex.
const CORNEA_RADIUS: f32 = 7.8;
const CORNEA_PROUD: f32 = 1.1;
const IRIS_DEPTH: f32 = 3.6;
const LIMBUS_RADIUS: f32 = 5.85;
// Refractive index of the cornea and aqueous humour (Le Grand: 1.376 / 1.336); one interface.
const CORNEA_N: f32 = 1.376;

@fragment
fn fs_eye(in: VertexOut, @builtin(front_facing) front: bool) -> GOut {
    var o: GOut;
    let v = normalize(frame.camera.xyz - in.world);
    let ng = normalize(in.normal);
    let c = draw.eye.xyz;
    let rg = draw.eye.w;
    let axis = draw.eye_axis.xyz;
    let xe = normalize(cross(vec3<f32>(0.0, 1.0, 0.0), axis));
    let ye = cross(axis, xe);
    let cc = c + axis * (rg + CORNEA_PROUD - CORNEA_RADIUS);
    let h_limbus = sqrt(max(rg * rg - LIMBUS_RADIUS * LIMBUS_RADIUS, 0.0));
    let dir = -v;
    let t = hit_sphere(frame.camera.xyz, dir, cc, CORNEA_RADIUS);
    var albedo: vec3<f32>;
    var spec_n = ng;
    var lit_n = ng;
    var lit_p = in.world;
    var transmit = 1.0;
    let q = frame.camera.xyz + dir * t;
    if (t > 0.0 && dot(q - c, axis) > h_limbus) {
        // Through the cornea: refract at its front surface and look the iris up where the ray
        // meets the iris plane (its UV on the globe's azimuthal map, derma-head's eye::uv_of).
        let nq = normalize(q - cc);
        let r = refract(dir, nq, 1.0 / CORNEA_N);
        let plane = rg + CORNEA_PROUD - IRIS_DEPTH;
        let denom = dot(r, axis);
        var s = q;
        if (denom < -1e-4) {
            s = q + r * ((plane - dot(q - c, axis)) / denom);
        }
        let local = vec2<f32>(dot(s - c, xe), dot(s - c, ye));
        let rho = length(local);
        let theta = asin(min(rho / rg, 1.0));
        let phi = atan2(local.y, local.x);
        let uv = vec2<f32>(0.5) + 0.5 * (theta / PI) * vec2<f32>(cos(phi), sin(phi));
        albedo = textureSample(base_color, tex_sampler, dilated_uv(uv)).rgb;
        spec_n = nq;
        lit_n = axis;
        lit_p = s;
        transmit = 1.0 - schlick(draw.params.y, max(dot(nq, v), 0.0));
    } else {
        albedo = textureSample(base_color, tex_sampler, tex_uv(dilated_uv(in.uv))).rgb;
    }
    // Diffuse from the iris or sclera; specular from the tear film over the cornea or sclera.
    let d = light_surface(lit_p, lit_n, ng, v, 1.0, 0.0);
    let s = light_surface(in.world, spec_n, ng, v, draw.params.x, draw.params.y);
    o.direct = vec4<f32>(d.diffuse * albedo * transmit + s.specular, 1.0);
    o.sss = vec4<f32>(view_depth(in.world), 0.0, 0.0, 0.0);
    // The globe for the lacrimal lake (lake.wgsl): its marker and geometric normal.
    o.post = vec4<f32>(ng * 0.5 + 0.5, MATERIAL_EYE);
    return o;
}

