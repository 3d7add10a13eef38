// The skin appearance rig of Jimenez et al. 2010 (eqs. 6–7, §6) evaluated on the GPU each time
// a weight changes: hemoglobin H = g·(Σ w_i bias_i + H_0 · Σ w_i scale_i); the colour is the
// texture set's own skin re-shaded with H (derma-rig's skin_response): base + d1·x + d2·x²,
// x = ∛H − ∛H_n, so a neutral frame is base_color.png and moles, lips and hair persist.
//
// Inputs are `derma export web`'s 16-bit PNGs (manifest.json states each file's value range).
// The fragment shader repeats derma-rig's rig.wgsl: basis maps upsampled bilinearly with clamp to
// edge and texel centres at half-integers; the skin (base, d1, d2) read per texel.
import * as THREE from 'three';
import { decodePng16 } from './png16.js';

/** Most basis layers the shader sums (the neutral plus 15 targets). */
export const MAX_LAYERS = 16;

/** Reads a 16-bit PNG and maps it to [range[0], range[1]]: {width, height, channels, data}. */
export async function png16(url, range) {
  const res = await fetch(url);
  if (!res.ok) throw new Error(`${url}: HTTP ${res.status}`);
  const img = await decodePng16(new Uint8Array(await res.arrayBuffer()), url);
  const [lo, hi] = range;
  const k = (hi - lo) / 65535;
  const data = new Float32Array(img.data.length);
  for (let i = 0; i < data.length; i++) data[i] = lo + k * img.data[i];
  return { width: img.width, height: img.height, channels: img.channels, data };
}

/** A float texture for texelFetch (rows from the image's top at t = 0, as glTF samples). */
export function floatTexture(img, wanted) {
  const { width, height, channels, data } = img;
  let out = data;
  if (channels !== wanted) {
    out = new Float32Array(width * height * wanted);
    for (let i = 0; i < width * height; i++) {
      for (let c = 0; c < wanted; c++) out[i * wanted + c] = c < channels ? data[i * channels + c] : 1;
    }
  }
  const format = wanted === 1 ? THREE.RedFormat : THREE.RGBAFormat;
  const t = new THREE.DataTexture(out, width, height, format, THREE.FloatType);
  t.minFilter = t.magFilter = THREE.NearestFilter;
  t.colorSpace = THREE.NoColorSpace;
  t.needsUpdate = true;
  return t;
}

const vertexShader = /* glsl */ `
void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }
`;

/**
 * A fragment shader run once per texel of a `width` × `height` texture (mipmapped, 8-bit,
 * `colorSpace`): the viewer's way of re-making a material's texture on the GPU. Row y of the
 * texture is gl_FragCoord.y = y + ½, rows from the image's top at t = 0 as glTF samples.
 */
export class TexturePass {
  constructor(width, height, colorSpace, fragmentShader, uniforms) {
    this.size = [width, height];
    this.target = new THREE.WebGLRenderTarget(width, height, {
      type: THREE.UnsignedByteType,
      colorSpace,
      generateMipmaps: true,
      minFilter: THREE.LinearMipmapLinearFilter,
      magFilter: THREE.LinearFilter,
      depthBuffer: false,
    });
    this.target.texture.anisotropy = 8;
    this.material = new THREE.ShaderMaterial({
      glslVersion: THREE.GLSL3,
      vertexShader,
      fragmentShader,
      depthTest: false,
      depthWrite: false,
      uniforms,
    });
    const quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), this.material);
    quad.frustumCulled = false;
    this.scene = new THREE.Scene();
    this.scene.add(quad);
    this.camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
  }

  /** Runs the shader into the texture. */
  render(renderer) {
    const previous = renderer.getRenderTarget();
    renderer.setRenderTarget(this.target);
    renderer.render(this.scene, this.camera);
    renderer.setRenderTarget(previous);
  }

  /** The texture as a PNG data URL (rows from the image's top, as the texture files). */
  toDataURL(renderer) {
    const [w, h] = this.size;
    const buf = new Uint8Array(w * h * 4);
    renderer.readRenderTargetPixels(this.target, 0, 0, w, h, buf);
    const c = document.createElement('canvas');
    c.width = w;
    c.height = h;
    c.getContext('2d').putImageData(new ImageData(new Uint8ClampedArray(buf.buffer), w, h), 0, 0);
    return c.toDataURL('image/png');
  }
}

const fragmentShader = /* glsl */ `
precision highp float;
precision highp int;
#define MAX_LAYERS ${MAX_LAYERS}
uniform sampler2D h0Tex;
uniform sampler2D melaninTex;
uniform sampler2D basisTex;
uniform sampler2D baseTex;
uniform sampler2D d1Tex;
uniform sampler2D d2Tex;
uniform float weights[MAX_LAYERS];
uniform int layers;
uniform ivec2 size;
uniform ivec2 basisSize;
uniform float globalScale;
uniform float melaninMax;
uniform float bloodMax;
uniform int mode;
out vec4 outColor;

// Source taps of output coordinate x when src texels are stretched over dst.
void tap(int x, int src, int dst, out int i0, out int i1, out float t) {
  float f = clamp((float(x) + 0.5) * float(src) / float(dst) - 0.5, 0.0, float(src - 1));
  i0 = min(int(floor(f)), src - 1);
  i1 = min(i0 + 1, src - 1);
  t = f - float(i0);
}

// g · Σ_i w_i · (bias_i, scale_i) at basis texel b: the weighted sums of eq. 6.
vec2 combined(ivec2 b) {
  vec2 s = vec2(0.0);
  for (int i = 0; i < MAX_LAYERS; i++) {
    if (i >= layers) break;
    s += weights[i] * texelFetch(basisTex, ivec2(b.x + i * basisSize.x, b.y), 0).rg;
  }
  return globalScale * s;
}

// The neutral's bias μ_n (tile 0) at basis texel b.
float neutralBias(ivec2 b) { return texelFetch(basisTex, b, 0).r; }

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  int x0, x1, y0, y1;
  float tx, ty;
  tap(p.x, basisSize.x, size.x, x0, x1, tx);
  tap(p.y, basisSize.y, size.y, y0, y1, ty);
  vec2 top = mix(combined(ivec2(x0, y0)), combined(ivec2(x1, y0)), tx);
  vec2 bottom = mix(combined(ivec2(x0, y1)), combined(ivec2(x1, y1)), tx);
  vec2 bs = mix(top, bottom, ty);
  float d0 = texelFetch(h0Tex, p, 0).r;
  float h = clamp(bs.x + d0 * bs.y, 0.0, 1.0);
  // H_n: the neutral pose (w_0 = 1, g = 1), upsampled as the frame's maps are.
  float nt = mix(neutralBias(ivec2(x0, y0)), neutralBias(ivec2(x1, y0)), tx);
  float nb = mix(neutralBias(ivec2(x0, y1)), neutralBias(ivec2(x1, y1)), tx);
  float hn = clamp(mix(nt, nb, ty) + d0, 0.0, 1.0);
  float cm = texelFetch(melaninTex, p, 0).r;
  vec3 c;
  if (mode == 1) c = vec3(pow(h / bloodMax, 1.0 / 3.0));
  else if (mode == 2) c = vec3(pow(max(cm, 0.0) / melaninMax, 1.0 / 3.0));
  else {
    float x = h == hn ? 0.0 : pow(h, 1.0 / 3.0) - pow(hn, 1.0 / 3.0);
    vec3 base = texelFetch(baseTex, p, 0).rgb;
    c = clamp(base + (texelFetch(d1Tex, p, 0).rgb + texelFetch(d2Tex, p, 0).rgb * x) * x, 0.0, 1.0);
  }
  outColor = vec4(c, 1.0);
}
`;

/** Display modes of the evaluated texture. */
export const MODES = { color: 0, hemoglobin: 1, melanin: 2 };

/**
 * The rig of a `derma export web` directory: `weights` by target name, `globalScale` ('auto' or
 * a factor), and `texture` (sRGB, the skin's albedo) re-rendered by `evaluate`.
 */
export class Rig {
  static async load(base, manifest) {
    const r = manifest.rig;
    if (!r.skin) throw new Error('manifest.json: the rig carries no skin (an export of derma before version 2); export it again');
    const [h0, melanin, basis, skinBase, d1, d2] = await Promise.all([
      png16(base + r.h0.file, r.h0.range),
      png16(base + r.melanin.file, r.melanin.range),
      png16(base + r.basis.file, [0, 1]),
      png16(base + r.skin.base.file, r.skin.base.range),
      png16(base + r.skin.d1.file, r.skin.d1.range),
      png16(base + r.skin.d2.file, r.skin.d2.range),
    ]);
    // The basis atlas holds bias (R) and scale (G), each normalised to its own range.
    const [bl, bh] = r.basis.bias_range;
    const [sl, sh] = r.basis.scale_range;
    for (let i = 0; i < basis.data.length; i += basis.channels) {
      basis.data[i] = bl + (bh - bl) * basis.data[i];
      basis.data[i + 1] = sl + (sh - sl) * basis.data[i + 1];
    }
    return new Rig(manifest, { h0, melanin, basis, skinBase, d1, d2 });
  }

  constructor(manifest, maps) {
    const r = manifest.rig;
    this.targets = r.targets.map((t) => t.name);
    this.suggested = r.targets.map((t) => t.global_scale);
    if (this.targets.length + 1 > MAX_LAYERS) {
      throw new Error(`manifest.json: ${this.targets.length} rig targets; the viewer takes at most ${MAX_LAYERS - 1}`);
    }
    this.weights = Object.fromEntries(this.targets.map((n) => [n, 0]));
    this.globalScale = 'auto';
    this.mode = MODES.color;
    const { width, height } = maps.h0;
    this.size = [width, height];
    const [bw, bh] = r.basis_size;
    this.pass = new TexturePass(width, height, THREE.SRGBColorSpace, fragmentShader, {
      h0Tex: { value: floatTexture(maps.h0, 1) },
      melaninTex: { value: floatTexture(maps.melanin, 1) },
      basisTex: { value: floatTexture(maps.basis, 4) },
      baseTex: { value: floatTexture(maps.skinBase, 4) },
      d1Tex: { value: floatTexture(maps.d1, 4) },
      d2Tex: { value: floatTexture(maps.d2, 4) },
      weights: { value: new Array(MAX_LAYERS).fill(0) },
      layers: { value: this.targets.length + 1 },
      size: { value: new THREE.Vector2(width, height) },
      basisSize: { value: new THREE.Vector2(bw, bh) },
      globalScale: { value: 1 },
      melaninMax: { value: r.lut.melanin_max },
      bloodMax: { value: r.lut.blood_max },
      mode: { value: 0 },
    });
    this.target = this.pass.target;
    this.material = this.pass.material;
  }

  /** w_0 … w_k as derma-rig forms them: the neutral takes the rest; above one, rescaled. */
  layerWeights() {
    const w = this.targets.map((n) => this.weights[n]);
    const rest = w.reduce((a, b) => a + b, 0);
    if (rest <= 1) return [Math.max(1 - rest, 0), ...w];
    return [0, ...w.map((x) => x / rest)];
  }

  /** derma-rig's global scale: a fixed factor, or 1 + Σ w_i (g_i − 1) for 'auto'. */
  scale(w) {
    if (this.globalScale !== 'auto') return this.globalScale;
    return 1 + w.slice(1).reduce((s, wi, i) => s + wi * (this.suggested[i] - 1), 0);
  }

  evaluate(renderer) {
    const w = this.layerWeights();
    const u = this.material.uniforms;
    w.forEach((x, i) => (u.weights.value[i] = x));
    u.globalScale.value = this.scale(w);
    u.mode.value = this.mode;
    this.pass.render(renderer);
  }

  /** The evaluated texture as a PNG data URL (sRGB, rows from the image's top). */
  toDataURL(renderer) {
    return this.pass.toDataURL(renderer);
  }

  /** sRGB bytes of the evaluated texture, averaged over (2r+1)² texels around (u, v), v up. */
  colorAt(renderer, u, v, r = 2) {
    const [w, h] = this.size;
    const x = Math.min(Math.max(Math.floor(u * w) - r, 0), w - 2 * r - 1);
    const y = Math.min(Math.max(Math.floor((1 - v) * h) - r, 0), h - 2 * r - 1);
    const n = 2 * r + 1;
    const buf = new Uint8Array(n * n * 4);
    renderer.readRenderTargetPixels(this.target, x, y, n, n, buf);
    const sum = [0, 0, 0];
    for (let i = 0; i < n * n; i++) for (let c = 0; c < 3; c++) sum[c] += buf[i * 4 + c];
    return sum.map((s) => s / (n * n));
  }
}
