// Screen-space subsurface scattering of the skin (Jimenez et al. 2015, "Separable subsurface
// scattering"): the skin's diffuse light, drawn alone, blurred along x then y by skin's diffusion
// profile scaled to each pixel's depth, and put back under everything else of the frame; the
// lacrimal lake (lake.js) reads the same diffuse target and joins the composite.
import * as THREE from 'three';
import { Lake, VIEW_DEPTH as DEPTH, LAKE_COMPOSITE } from './lake.js';

// Skin's diffusion profile as six Gaussians (d'Eon & Luebke 2007, GPU Gems 3 ch. 14, table
// 14-1, the three-layer skin fit): variance (mm²) and the RGB weight of each.
const GAUSSIANS = [
  [0.0064, [0.233, 0.455, 0.649]],
  [0.0484, [0.1, 0.336, 0.344]],
  [0.187, [0.118, 0.198, 0.0]],
  [0.567, [0.113, 0.007, 0.007]],
  [1.99, [0.358, 0.004, 0.0]],
  [7.41, [0.078, 0.0, 0.0]],
];
// Taps of the 1-D kernel, spanning ±RANGE_MM with more of them near the centre (offsets grow
// as the square of the tap's index, as Jimenez et al.'s kernels do).
const TAPS = 17;
const RANGE_MM = 8;

/** The 1-D kernel: per tap its offset (mm) and RGB weights, each channel summing to 1. */
export function kernel() {
  const half = (TAPS - 1) / 2;
  const taps = [];
  for (let k = -half; k <= half; k++) {
    const o = Math.sign(k) * RANGE_MM * (k / half) ** 2;
    taps.push(o);
  }
  const weights = taps.map((o, k) => {
    // The tap's share of the line: half the distance to each neighbour.
    const lo = k > 0 ? (o + taps[k - 1]) / 2 : o;
    const hi = k < TAPS - 1 ? (o + taps[k + 1]) / 2 : o;
    const width = Math.max(hi - lo, 1e-3);
    return [0, 1, 2].map((c) =>
      GAUSSIANS.reduce((s, [v, w]) => s + w[c] * Math.exp((-o * o) / (2 * v)) / Math.sqrt(2 * Math.PI * v), 0) * width,
    );
  });
  const sums = [0, 1, 2].map((c) => weights.reduce((s, w) => s + w[c], 0));
  return taps.map((o, k) => [o, weights[k].map((w, c) => w / sums[c])]);
}

const QUAD_VS = /* glsl */ `
varying vec2 vUv;
void main() { vUv = uv; gl_Position = vec4(position.xy, 0.0, 1.0); }
`;

function blurShader(taps) {
  const list = taps.map(([o, w]) => `vec4(${o.toFixed(6)}, ${w.map((x) => x.toFixed(6)).join(', ')})`).join(',\n  ');
  return /* glsl */ `
varying vec2 vUv;
uniform sampler2D source;
uniform sampler2D depth;
uniform vec2 step;     // one pixel along the blur's direction, in UV
uniform float focal;   // pixels per unit of tan: px = focal · (metres / depth)
${DEPTH}
const vec4 TAPS[${taps.length}] = vec4[](
  ${list}
);
void main() {
  vec4 c = texture2D(source, vUv);
  if (c.a <= 0.75) { gl_FragColor = c; return; }
  float z = viewDepth(texture2D(depth, vUv).x);
  // One millimetre on the skin, in pixels here.
  float px = focal * 0.001 / z;
  vec3 sum = vec3(0.0);
  for (int k = 0; k < ${taps.length}; k++) {
    vec2 uv = vUv + step * TAPS[k].x * px;
    vec4 s = texture2D(source, uv);
    float zs = viewDepth(texture2D(depth, uv).x);
    // Follow the surface (Jimenez et al. 2015 §3): across a depth step of a few mm, or off the
    // skin, the sample is the centre's.
    float keep = s.a > 0.75 ? clamp(1.0 - abs(zs - z) / 0.003, 0.0, 1.0) : 0.0;
    sum += TAPS[k].yzw * mix(c.rgb, s.rgb, keep);
  }
  gl_FragColor = vec4(sum, c.a);
}
`;
}

const COMPOSITE_FS = /* glsl */ `
varying vec2 vUv;
uniform sampler2D full;
uniform sampler2D fullDepth;
uniform sampler2D blurred;
uniform float scatter;   // 1: the skin's diffuse light replaced by the blurred, 0: kept
uniform float lakeOn;
${DEPTH}
${LAKE_COMPOSITE}
void main() {
  vec4 f = texture2D(full, vUv);
  if (texture2D(fullDepth, vUv).x >= 1.0) {
    // The background: its colour as the canvas draws it, not tone-mapped.
    gl_FragColor = vec4(f.rgb, 1.0);
    #include <colorspace_fragment>
    return;
  }
  vec4 d = texture2D(diffuse, vUv);
  float z = viewDepth(texture2D(fullDepth, vUv).x);
  // Where the diffuse target's surface is what the frame shows (no card or part before it).
  bool shown = abs(viewDepth(texture2D(diffuseDepth, vUv).x) - z) < 0.0005;
  vec3 rgb = f.rgb;
  if (shown && d.a > 0.75) rgb += scatter * (texture2D(blurred, vUv).rgb - d.rgb);
  if (shown && lakeOn > 0.5) rgb = lakeOver(rgb, z);
  gl_FragColor = vec4(rgb, 1.0);
  #include <tonemapping_fragment>
  #include <colorspace_fragment>
}
`;

/** The separable SSS and the lacrimal lake over `renderer`'s frames; `render(scene, camera,
 * skin)` draws a frame. */
export class Sss {
  constructor(renderer) {
    this.renderer = renderer;
    this.enabled = true;
    const target = () => {
      const t = new THREE.WebGLRenderTarget(1, 1, { type: THREE.HalfFloatType });
      t.depthTexture = new THREE.DepthTexture(1, 1);
      return t;
    };
    this.full = target();
    this.diffuse = target();
    this.ping = new THREE.WebGLRenderTarget(1, 1, { type: THREE.HalfFloatType });
    this.pong = new THREE.WebGLRenderTarget(1, 1, { type: THREE.HalfFloatType });
    // Shared by the passes: the depth range, the focal length (px), the diffuse target.
    const shared = {
      near: { value: 0.01 },
      far: { value: 100 },
      focal: { value: 1 },
      diffuse: { value: this.diffuse.texture },
      diffuseDepth: { value: this.diffuse.depthTexture },
    };
    this.lake = new Lake(shared);
    this.blurMat = new THREE.ShaderMaterial({
      vertexShader: QUAD_VS,
      fragmentShader: blurShader(kernel()),
      uniforms: { ...shared, source: { value: null }, depth: { value: null }, step: { value: new THREE.Vector2() } },
      depthTest: false,
      depthWrite: false,
    });
    this.compMat = new THREE.ShaderMaterial({
      vertexShader: QUAD_VS,
      fragmentShader: COMPOSITE_FS,
      uniforms: {
        ...shared,
        ...this.lake.uniforms,
        full: { value: this.full.texture },
        fullDepth: { value: this.full.depthTexture },
        blurred: { value: this.pong.texture },
        scatter: { value: 1 },
        lakeOn: { value: 0 },
      },
      depthTest: false,
      depthWrite: false,
    });
    this.compMat.toneMapped = true;
    this.quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), this.blurMat);
    this.quadScene = new THREE.Scene();
    this.quadScene.add(this.quad);
    this.quadCamera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
    this.shared = shared;
    this.depthOnly = new THREE.MeshBasicMaterial({ colorWrite: false });
  }

  setSize(w, h) {
    for (const t of [this.full, this.diffuse, this.ping, this.pong, this.lake.target]) t.setSize(w, h);
  }

  /** A full-screen pass of `material` into `target`. */
  pass(material, target) {
    this.quad.material = material;
    this.renderer.setRenderTarget(target);
    this.renderer.render(this.quadScene, this.quadCamera);
  }

  /** One frame: the whole scene; the skin's diffuse light alone (the globes as the lake's
   * markers); its blur along x then y; the lake's distances; the composite to the canvas. */
  render(scene, camera, skin) {
    const r = this.renderer;
    const lake = this.lake.enabled ? this.lake : null;
    if ((!this.enabled && !lake) || !skin) {
      r.setRenderTarget(null);
      r.render(scene, camera);
      return;
    }
    const size = r.getDrawingBufferSize(new THREE.Vector2());
    if (this.full.width !== size.x || this.full.height !== size.y) this.setSize(size.x, size.y);
    this.shared.near.value = camera.near;
    this.shared.far.value = camera.far;
    this.shared.focal.value = (0.5 * size.y) / Math.tan((camera.fov * Math.PI) / 360);
    r.setRenderTarget(this.full);
    r.render(scene, camera);
    this.drawDiffuse(scene, camera, skin, lake);
    if (this.enabled) {
      const u = this.blurMat.uniforms;
      u.depth.value = this.diffuse.depthTexture;
      u.source.value = this.diffuse.texture;
      u.step.value.set(1 / size.x, 0);
      this.pass(this.blurMat, this.ping);
      u.source.value = this.ping.texture;
      u.step.value.set(0, 1 / size.y);
      this.pass(this.blurMat, this.pong);
    }
    if (lake) {
      lake.lights(scene, camera);
      this.pass(lake.depthMat, lake.target);
    }
    this.compMat.uniforms.scatter.value = this.enabled ? 1 : 0;
    this.compMat.uniforms.lakeOn.value = lake ? 1 : 0;
    this.pass(this.compMat, null);
  }

  /** The skin alone, its specular off: the diffuse light to scatter. Opaque parts (globes,
   * teeth) still hide what lies behind them, in depth only, or the globes as the lake's markers
   * (their view-space normal, alpha ½); blended cards are left out. */
  drawDiffuse(scene, camera, skin, lake) {
    const r = this.renderer;
    const hidden = [];
    const masked = [];
    scene.traverseVisible((o) => {
      if (!o.isMesh || o === skin) return;
      if (o.material.transparent) hidden.push(o);
      else masked.push([o, o.material]);
    });
    for (const o of hidden) o.visible = false;
    for (const [o, mat] of masked) o.material = lake && mat.userData.cornea ? lake.marker : this.depthOnly;
    const m = skin.material;
    const spec = m.specularIntensity;
    m.specularIntensity = 0;
    const bg = scene.background;
    const [clear, alpha] = [r.getClearColor(new THREE.Color()), r.getClearAlpha()];
    scene.background = null;
    r.setClearColor(0x000000, 0);
    r.setRenderTarget(this.diffuse);
    r.clear();
    r.render(scene, camera);
    scene.background = bg;
    r.setClearColor(clear, alpha);
    m.specularIntensity = spec;
    for (const o of hidden) o.visible = true;
    for (const [o, mat] of masked) o.material = mat;
  }
}
