// Expression wrinkles in the viewer (Jimenez et al. 2011: a wrinkle map blended per region by
// masks and per-expression weights; derma_head::wrinkle_regions): the skin's normal map is
// re-made on the GPU whenever the face units change, as manifest.json's formula states —
// w_r = clamp(Σ_u gain_{r,u}·unit_u, 0, 1), m = clamp(Σ_r w_r·mask_r, 0, 1),
// n = normalize(lerp(n_rest, n_wrinkled, m)). Texels with m = 0 keep the rest normal.
import * as THREE from 'three';
import { png16, floatTexture, TexturePass } from './rig.js';

const fragmentShader = /* glsl */ `
precision highp float;
uniform sampler2D restTex;
uniform sampler2D fullTex;
uniform sampler2D mask0;
uniform sampler2D mask1;
uniform sampler2D mask2;
uniform sampler2D mask3;
uniform vec3 w0;
uniform vec3 w1;
uniform vec3 w2;
uniform vec3 w3;
uniform ivec2 size;
out vec4 outColor;

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec2 uv = (vec2(p) + 0.5) / vec2(size);
  vec3 rest = texture(restTex, uv).rgb;
  float m = dot(texture(mask0, uv).rgb, w0) + dot(texture(mask1, uv).rgb, w1)
    + dot(texture(mask2, uv).rgb, w2) + dot(texture(mask3, uv).rgb, w3);
  m = clamp(m, 0.0, 1.0);
  vec3 c = rest;
  if (m > 0.0) {
    vec3 full = texelFetch(fullTex, p, 0).rgb;
    c = normalize(mix(rest * 2.0 - 1.0, full * 2.0 - 1.0, m)) * 0.5 + 0.5;
  }
  outColor = vec4(c, 1.0);
}
`;

/** An 8-bit RGBA texture of a decoded 16-bit image in [0, 1], bilinearly filtered. */
function byteTexture(img) {
  const { width, height, channels, data } = img;
  const out = new Uint8Array(width * height * 4);
  for (let i = 0; i < width * height; i++) {
    for (let c = 0; c < 4; c++) out[i * 4 + c] = c < channels ? Math.round(255 * data[i * channels + c]) : 255;
  }
  const t = new THREE.DataTexture(out, width, height, THREE.RGBAFormat, THREE.UnsignedByteType);
  t.minFilter = t.magFilter = THREE.LinearFilter;
  t.colorSpace = THREE.NoColorSpace;
  t.needsUpdate = true;
  return t;
}

/** The expression wrinkles of a `derma export web` directory over the skin's rest normal map. */
export class Wrinkles {
  static async load(base, manifest, restNormal) {
    const w = manifest.wrinkles;
    const full = await png16(base + w.normal.file, [0, 1]);
    const masks = await Promise.all(w.masks.map((m) => png16(base + m.file, [0, 1])));
    return new Wrinkles(w, restNormal, full, masks);
  }

  constructor(spec, restNormal, full, masks) {
    if (masks.length > 4) throw new Error(`manifest.json: ${masks.length} wrinkle mask images; the viewer takes 4`);
    // Region order of the mask channels, and each region's face-unit drivers.
    this.regions = spec.masks.flatMap((m) => m.channels);
    this.drivers = Object.fromEntries(spec.regions.map((r) => [r.name, r.drivers]));
    const maskTex = masks.map(byteTexture);
    while (maskTex.length < 4) maskTex.push(byteTexture({ width: 1, height: 1, channels: 1, data: [0] }));
    this.pass = new TexturePass(full.width, full.height, THREE.NoColorSpace, fragmentShader, {
      restTex: { value: restNormal },
      fullTex: { value: floatTexture(full, 4) },
      mask0: { value: maskTex[0] },
      mask1: { value: maskTex[1] },
      mask2: { value: maskTex[2] },
      mask3: { value: maskTex[3] },
      w0: { value: new THREE.Vector3() },
      w1: { value: new THREE.Vector3() },
      w2: { value: new THREE.Vector3() },
      w3: { value: new THREE.Vector3() },
      size: { value: new THREE.Vector2(full.width, full.height) },
    });
    this.target = this.pass.target;
    this.key = null;
  }

  /** Region weights w_r from face-unit weights `units` (by name), in mask-channel order. */
  weights(units) {
    return this.regions.map((r) => {
      const s = Object.entries(this.drivers[r] ?? {}).reduce((a, [u, g]) => a + g * (units[u] ?? 0), 0);
      return Math.min(Math.max(s, 0), 1);
    });
  }

  /** Re-makes the normal map for `units` when the region weights changed; true if it did. */
  evaluate(renderer, units) {
    const w = this.weights(units);
    const key = w.join(',');
    if (key === this.key) return false;
    this.key = key;
    const u = this.pass.material.uniforms;
    const at = (i) => w[i] ?? 0;
    [u.w0, u.w1, u.w2, u.w3].forEach((x, k) => x.value.set(at(3 * k), at(3 * k + 1), at(3 * k + 2)));
    this.pass.render(renderer);
    return true;
  }

  /** The blended normal map as a PNG data URL (rows from the image's top). */
  toDataURL(renderer) {
    return this.pass.toDataURL(renderer);
  }
}
