// The lacrimal lake (EyeMove thesis §4.5) in the viewer, as derma render's lake.wgsl draws it:
// each globe pixel's screen-space distance λ to the skin gives a meniscus depth falling linearly
// to nothing at Λ; the depth's slope tilts the globe's normal; the fluid absorbs along the
// light's double pass and adds its highlight. Its constants come from the export (lake.rs).
import * as THREE from 'three';

/** Linear view depth (m) from a perspective depth buffer. */
export const VIEW_DEPTH = /* glsl */ `
uniform float near;
uniform float far;
float viewDepth(float d) {
  float z = d * 2.0 - 1.0;
  return 2.0 * near * far / (far + near - z * (far - near));
}
`;

/** Shared by both passes: the materials' markers in the diffuse target's alpha (skin 1, globes
 * ½ with their view-space normal in rgb) and pixels per mm at a view depth. */
const MARKERS = /* glsl */ `
uniform sampler2D diffuse;
uniform sampler2D diffuseDepth;
uniform float focal;   // pixels per unit of tan
uniform vec4 shape;    // x meniscus height at the margin (mm), y reach Λ (mm), z attenuation (1/mm), w F0
bool isSkin(ivec2 p) {
  ivec2 size = textureSize(diffuse, 0);
  if (any(lessThan(p, ivec2(0))) || any(greaterThanEqual(p, size))) return false;
  return texelFetch(diffuse, p, 0).a > 0.75;
}
bool isGlobe(vec4 d) { return abs(d.a - 0.5) < 0.1; }
float pxPerMm(float z) { return focal * 0.001 / z; }
`;

const DEPTH_FS = /* glsl */ `
${VIEW_DEPTH}
${MARKERS}
uniform float maxSearch;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  if (!isGlobe(texelFetch(diffuse, p, 0))) { gl_FragColor = vec4(0.0); return; }
  float ppm = pxPerMm(viewDepth(texelFetch(diffuseDepth, p, 0).x));
  int reach = int(ceil(shape.y * ppm));
  // Square rings outwards; a pixel on ring r is at least r away, so stop once r² passes the
  // best squared distance found. The viewer zooms freely: where Λ spans more than the search's
  // most pixels, the rings and their texels are taken every ⌈reach / most⌉ px, so the lake
  // keeps its width (to within that step) instead of ending short of Λ.
  int stride = max(1, (reach + int(maxSearch) - 1) / int(maxSearch));
  float best = 1e30;
  for (int r = stride; r <= reach; r += stride) {
    if (float(r * r) >= best) break;
    for (int k = -r; k <= r; k += stride) {
      float d2 = float(k * k + r * r);
      if (d2 >= best) continue;
      if (isSkin(p + ivec2(k, -r)) || isSkin(p + ivec2(k, r)) || isSkin(p + ivec2(-r, k)) || isSkin(p + ivec2(r, k))) best = d2;
    }
  }
  float lambda = sqrt(best) / ppm;
  gl_FragColor = lambda >= shape.y ? vec4(0.0) : vec4(shape.x * (1.0 - lambda / shape.y), 0.0, 0.0, 0.0);
}
`;

/** The composite's part: `lakeOver(rgb)` puts the lake over a globe pixel's radiance. */
export const LAKE_COMPOSITE = /* glsl */ `
${MARKERS}
uniform sampler2D lakeDepth;
uniform float roughness;
uniform vec3 lightDir[2];     // view space, towards each directional light
uniform vec3 lightColor[2];   // colour × intensity
float lakeAt(ivec2 p) {
  p = clamp(p, ivec2(0), textureSize(lakeDepth, 0) - 1);
  return isSkin(p) ? shape.x : texelFetch(lakeDepth, p, 0).x;
}
vec3 lakeOver(vec3 rgb, float z) {
  ivec2 p = ivec2(gl_FragCoord.xy);
  float d = texelFetch(lakeDepth, p, 0).x;
  vec4 m = texelFetch(diffuse, p, 0);
  if (d <= 0.0 || !isGlobe(m)) return rgb;
  float mm = 1.0 / pxPerMm(z);
  // The depth's slope (mm per mm, right and up) tilts the normal away from the lid.
  float dx = (lakeAt(p + ivec2(1, 0)) - lakeAt(p - ivec2(1, 0))) / (2.0 * mm);
  float dy = (lakeAt(p + ivec2(0, 1)) - lakeAt(p - ivec2(0, 1))) / (2.0 * mm);
  vec3 n = normalize(normalize(m.rgb * 2.0 - 1.0) - vec3(dx, dy, 0.0));
  vec2 c = (gl_FragCoord.xy - 0.5 * vec2(textureSize(diffuse, 0))) / focal;
  vec3 v = normalize(-vec3(c * z, -z));
  // GGX (Walter et al. 2007) with the height-correlated Smith visibility (Heitz 2014) and
  // Schlick's Fresnel (1994), lit as three.js lights its direct lights (radiance × n·l).
  float a = max(roughness * roughness, 0.002);
  float a2 = a * a;
  float nv = max(dot(n, v), 1e-4);
  vec3 spec = vec3(0.0);
  for (int i = 0; i < 2; i++) {
    vec3 l = lightDir[i];
    float nl = max(dot(n, l), 0.0);
    if (nl <= 0.0) continue;
    vec3 h = normalize(l + v);
    float nh = max(dot(n, h), 0.0);
    float dd = nh * nh * (a2 - 1.0) + 1.0;
    float D = a2 / (3.14159265 * dd * dd);
    float V = 0.5 / (nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2));
    float F = shape.w + (1.0 - shape.w) * pow(1.0 - max(dot(v, h), 0.0), 5.0);
    spec += lightColor[i] * nl * D * V * F;
  }
  return rgb * exp(-2.0 * shape.z * d) + spec;
}
`;

/**
 * The lake's passes over the SSS's diffuse target: the globes drawn there as markers, the
 * distance pass into `target`, and the uniforms the composite reads. Off until [`configure`]d
 * with the export's constants.
 */
export class Lake {
  constructor(shared) {
    this.enabled = false;
    this.target = new THREE.WebGLRenderTarget(1, 1, { type: THREE.HalfFloatType });
    this.marker = new THREE.MeshNormalMaterial({ transparent: true, opacity: 0.5, blending: THREE.NoBlending });
    this.uniforms = {
      shape: { value: new THREE.Vector4() },
      roughness: { value: 1 },
      maxSearch: { value: 0 },
      lightDir: { value: [new THREE.Vector3(), new THREE.Vector3()] },
      lightColor: { value: [new THREE.Vector3(), new THREE.Vector3()] },
      lakeDepth: { value: this.target.texture },
    };
    this.depthMat = new THREE.ShaderMaterial({
      vertexShader: /* glsl */ 'void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }',
      fragmentShader: DEPTH_FS,
      uniforms: { ...shared, ...this.uniforms },
      depthTest: false,
      depthWrite: false,
    });
  }

  /** The export's `eyes.lake` (derma-render's lake.rs constants); the lake is then drawn. */
  configure(c) {
    const u = this.uniforms;
    u.shape.value.set(c.meniscus_mm, c.range_mm, c.attenuation_per_mm, c.f0);
    u.roughness.value = c.roughness;
    u.maxSearch.value = c.max_search_px;
    this.enabled = true;
  }

  /** The scene's two strongest directional lights, in view space, into the uniforms. */
  lights(scene, camera) {
    const found = [];
    scene.traverseVisible((o) => o.isDirectionalLight && found.push(o));
    found.sort((a, b) => b.intensity - a.intensity);
    const u = this.uniforms;
    for (let i = 0; i < 2; i++) {
      const l = found[i];
      if (!l) {
        u.lightColor.value[i].set(0, 0, 0);
        continue;
      }
      const d = new THREE.Vector3().subVectors(l.getWorldPosition(new THREE.Vector3()), l.target.getWorldPosition(new THREE.Vector3()));
      u.lightDir.value[i].copy(d.transformDirection(camera.matrixWorldInverse));
      u.lightColor.value[i].set(l.color.r, l.color.g, l.color.b).multiplyScalar(l.intensity);
    }
  }
}
