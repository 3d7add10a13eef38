// The trained eye-region model in the skin's vertex shader (EyeMove thesis §3.9: "the model is
// evaluated in a vertex shader"): per vertex what eyes.js' vertexAt does, from data textures.
// The per-frame quantities (e = W g̃, the globes' rotations, the lids' contact) stay in eyes.js.
import * as THREE from 'three';

/** Texels per row of the per-vertex data texture. */
const WIDTH = 2000;
/** Scalars per vertex besides the linear coefficients: offset (3), lift, normal offset (3),
 * eye, slide (6), rest normal (3). */
const EXTRAS = 17;

/**
 * The model's per-vertex arrays as one RGBA float texture: per vertex `pairs` texel pairs, pair
 * j holding (basis x_j, basis y_j, two extras) and (z_j, n_x j, n_y j, n_z j), where j = 0 is the
 * value at e = 0 and j ≥ 1 the coefficient of e_{j−1} (zero past the model's k).
 */
export function packVertices(m) {
  const k = m.k;
  const kd = m.h.depth.k;
  const pairs = Math.max(Math.max(k, kd) + 1, Math.ceil(EXTRAS / 2));
  const stride = 2 * pairs;
  const rows = Math.ceil((m.n * stride) / WIDTH);
  const data = new Float32Array(WIDTH * rows * 4);
  const k1 = kd + 1;
  for (let i = 0; i < m.n; i++) {
    const extras = [
      ...m.offset.subarray(3 * i, 3 * i + 3),
      m.lift[i],
      ...m.normal_offset.subarray(3 * i, 3 * i + 3),
      m.eye[i],
      ...m.slide.subarray(6 * i, 6 * i + 6),
      ...m.rest_normals.subarray(3 * i, 3 * i + 3),
    ];
    const b = 4 * k1 * i;
    for (let j = 0; j < pairs; j++) {
      const a = 4 * (i * stride + 2 * j);
      if (j <= k) {
        data[a] = m.basis[i * 2 * (k + 1) + 2 * j];
        data[a + 1] = m.basis[i * 2 * (k + 1) + 2 * j + 1];
      }
      data[a + 2] = extras[2 * j] ?? 0;
      data[a + 3] = extras[2 * j + 1] ?? 0;
      if (j <= kd) for (let q = 0; q < 4; q++) data[a + 4 + q] = m.depth[b + q * k1 + j];
    }
  }
  const tex = new THREE.DataTexture(data, WIDTH, rows, THREE.RGBAFormat, THREE.FloatType);
  tex.needsUpdate = true;
  return { tex, pairs, stride };
}

const decls = (c) => /* glsl */ `
uniform highp sampler2D eyeData;
uniform highp sampler2D eyeRadial;
uniform highp sampler2D eyeShort;
uniform vec4 eyeE[${c.evec}];
uniform mat3 eyeRot[2];
uniform vec4 eyeCentre[2];   // xyz the globe's centre (mm), w its reach
uniform ivec2 eyeShortN;     // points of each eye's contact polyline (0: none)
uniform bool eyeOn;
uniform ivec4 eyeRegionBits; // the region's own face units among the morphs, 31 to a lane
attribute float eyeVertex;   // the model vertex this skin vertex is, or −1

bool eyeRegionUnit(int i) { return ((eyeRegionBits[i / 31] >> (i % 31)) & 1) == 1; }

float eyeCoef(int j) { return j == 0 ? 1.0 : eyeE[(j - 1) / 4][(j - 1) % 4]; }

vec4 eyeTexel(int v, int j) {
  int t = v * ${c.stride} + j;
  return texelFetch(eyeData, ivec2(t % ${WIDTH}, t / ${WIDTH}), 0);
}

// The contact polyline's height at x (linear between its points; 0 outside it).
float eyeHeightAt(int e, float x) {
  for (int j = 0; j + 1 < eyeShortN[e]; j++) {
    vec2 a = texelFetch(eyeShort, ivec2(j, e), 0).xy;
    vec2 b = texelFetch(eyeShort, ivec2(j + 1, e), 0).xy;
    float lo = min(a.x, b.x);
    float hi = max(a.x, b.x);
    if (x >= lo && x <= hi && hi > lo) return a.y + (b.y - a.y) * (x - a.x) / (b.x - a.x);
  }
  return 0.0;
}

// D(dir): the globe's radial distance along a unit direction of its frame (octahedral, bilinear).
float eyeRadius(int e, vec3 d) {
  vec2 p = d.xy / (abs(d.x) + abs(d.y) + abs(d.z));
  if (d.z < 0.0) p = (1.0 - abs(p.yx)) * vec2(p.x >= 0.0 ? 1.0 : -1.0, p.y >= 0.0 ? 1.0 : -1.0);
  float size = ${c.radial}.0;
  vec2 f = clamp((p * 0.5 + 0.5) * size - 0.5, 0.0, size - 1.0 - 1e-3);
  ivec2 i = ivec2(floor(f));
  vec2 t = f - vec2(i);
  int row = e * ${c.radial} + i.y;
  float top = mix(texelFetch(eyeRadial, ivec2(i.x, row), 0).x, texelFetch(eyeRadial, ivec2(i.x + 1, row), 0).x, t.x);
  float bot = mix(texelFetch(eyeRadial, ivec2(i.x, row + 1), 0).x, texelFetch(eyeRadial, ivec2(i.x + 1, row + 1), 0).x, t.x);
  return mix(top, bot, t.y);
}

// Vertex v's position (mm) and normal: ũ⁺ linear in e, the lids' contact, depth and normal
// linear in e, then Algorithm 1's sliding on the turned globe (eyes.js' vertexAt and slideAt).
void eyeEval(int v, out vec3 pos, out vec3 nrm) {
  vec2 u = vec2(0.0);
  vec4 zn = vec4(0.0);
  float ex[${2 * c.pairs}];
  for (int j = 0; j < ${c.pairs}; j++) {
    vec4 a = eyeTexel(v, 2 * j);
    float w = eyeCoef(j);
    u += w * a.xy;
    zn += w * eyeTexel(v, 2 * j + 1);
    ex[2 * j] = a.z;
    ex[2 * j + 1] = a.w;
  }
  int e = int(ex[7]);
  if (ex[3] > 0.0 && eyeShortN[e] > 0) u.y += ex[3] * eyeHeightAt(e, u.x);
  float nl = length(zn.yzw);
  vec3 m = nl > 0.0 ? zn.yzw / nl : vec3(0.0, 0.0, 1.0);
  pos = vec3(u, zn.x) + vec3(ex[0], ex[1], ex[2]);
  nrm = normalize(m + vec3(ex[4], ex[5], ex[6]));
  float kind = ex[8];
  if (kind < 0.0) return;
  float t = ex[9];
  mat3 R = eyeRot[e];
  vec3 c = eyeCentre[e].xyz;
  vec3 r = transpose(R) * (pos - c);
  float len = max(length(r), 1e-6);
  if (kind == 0.0 && len >= eyeCentre[e].w + t) return;
  vec3 d = r / len;
  vec3 tau = R * d;
  if (kind == 0.0) {
    float delta = eyeRadius(e, d) + t;
    if (delta > len) {
      pos = c + tau * delta;
      nrm = tau;
    }
  } else {
    pos = c + tau * (eyeRadius(e, d) + t + ex[10]);
    nrm = normalize(vec3(ex[14], ex[15], ex[16]) + tau - vec3(ex[11], ex[12], ex[13]));
  }
}
`;

// The region's vertices: the model's position, plus what the face units outside the region
// add (a raised brow, a smile's cheeks), as derma render composes them; the region's own units
// are the model's to pose, so their offsets are taken back off.
const REPLACE = /* glsl */ `
  if (eyeHere) {
    vec3 others = transformed - eyeBefore;
  #ifdef USE_MORPHTARGETS
    for (int i = 0; i < MORPHTARGETS_COUNT; i++) {
      if (morphTargetInfluences[i] != 0.0 && eyeRegionUnit(i)) others -= getMorph(gl_VertexID, i, 0).xyz * morphTargetInfluences[i];
    }
  #endif
    transformed = eyePos * 0.001 + others;
  }`;

/** The region units' morph indices on `skin` as bits, 31 to a lane (bit i % 31 of lane i / 31). */
function regionBits(m, skin) {
  const bits = [0, 0, 0, 0];
  for (const u of m.h.region_units) {
    const i = skin.morphTargetDictionary?.[u];
    if (i === undefined) continue;
    if (i >= 124) throw new Error(`eye model: face unit '${u}' is morph ${i}; the shader marks at most 124`);
    bits[Math.floor(i / 31)] |= 1 << i % 31;
  }
  return new THREE.Vector4(...bits);
}

/** The model's vertex shader over the skin: its data, its uniforms, and the materials it is in. */
export class EyeShader {
  constructor(model, skin) {
    const m = model;
    const { tex, pairs, stride } = packVertices(m);
    const size = m.h.radial.size;
    const radial = new THREE.DataTexture(m.radial, size, 2 * size, THREE.RedFormat, THREE.FloatType);
    radial.needsUpdate = true;
    this.points = Math.max(...m.h.margins.map(([upper]) => upper.length));
    this.short = new THREE.DataTexture(new Float32Array(4 * this.points * 2), this.points, 2, THREE.RGBAFormat, THREE.FloatType);
    this.short.needsUpdate = true;
    const evec = Math.ceil((pairs - 1) / 4);
    this.uniforms = {
      eyeData: { value: tex },
      eyeRadial: { value: radial },
      eyeShort: { value: this.short },
      eyeE: { value: Array.from({ length: evec }, () => new THREE.Vector4()) },
      eyeRot: { value: [new THREE.Matrix3(), new THREE.Matrix3()] },
      eyeCentre: { value: m.h.centres.map((c, e) => new THREE.Vector4(...c, m.h.radial.reach[e])) },
      eyeShortN: { value: new THREE.Vector2(0, 0) },
      eyeOn: { value: false },
      eyeRegionBits: { value: regionBits(m, skin) },
    };
    this.glsl = decls({ evec, stride, pairs, radial: size });
    this.key = [evec, stride, pairs, size].join('-');
    // Each skin vertex's model vertex (−1 outside the region).
    const geo = skin.geometry;
    const index = new Float32Array(geo.attributes.position.count).fill(-1);
    const sv = m.skin_vertices;
    for (let j = 0; j < sv.length; j += 2) index[sv[j]] = sv[j + 1];
    geo.setAttribute('eyeVertex', new THREE.BufferAttribute(index, 1));
  }

  /** Puts the model into `material`'s vertex shader (a three.js built-in material). */
  patch(material) {
    material.onBeforeCompile = (shader) => {
      Object.assign(shader.uniforms, this.uniforms);
      shader.vertexShader = shader.vertexShader
        .replace('#include <common>', `#include <common>\n${this.glsl}`)
        .replace('void main() {', 'void main() {\n  vec3 eyePos, eyeNrm;\n  bool eyeHere = eyeOn && eyeVertex >= 0.0;\n  if (eyeHere) eyeEval(int(eyeVertex), eyePos, eyeNrm);')
        .replace('#include <morphnormal_vertex>', '#include <morphnormal_vertex>\n  if (eyeHere) objectNormal = eyeNrm;')
        .replace('#include <morphtarget_vertex>', `vec3 eyeBefore = transformed;\n#include <morphtarget_vertex>\n${REPLACE}`);
    };
    // The sizes baked into the shader's text key its program.
    material.customProgramCacheKey = () => `derma-eye-model-${this.key}`;
    material.needsUpdate = true;
  }

  /** The model's pose (eyes.js' pose()) into the uniforms; `on` false draws the rest mesh. */
  update(m, on) {
    const u = this.uniforms;
    u.eyeOn.value = on;
    if (!on) return;
    u.eyeE.value.forEach((v, i) => v.set(...[0, 1, 2, 3].map((q) => m.e[4 * i + q] ?? 0)));
    m.rot.forEach((R, e) => u.eyeRot.value[e].set(...R));
    const data = this.short.image.data;
    const n = m.short.map((s, e) => {
      (s ?? []).forEach(([x, y], j) => data.set([x, y], 4 * (e * this.points + j)));
      return s ? s.length : 0;
    });
    u.eyeShortN.value.set(n[0], n[1]);
    this.short.needsUpdate = true;
  }
}
