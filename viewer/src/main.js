// derma's web viewer: the head of `derma export web` lit by an image-based environment and a
// key light, its albedo re-evaluated from the skin appearance rig (Jimenez et al. 2010 §6) and its
// normal map from the expression wrinkles (wrinkles.js) as expression sliders move, and the lids
// and the skin around the eyes from the trained eye-region model (eyes.js) as gaze, aperture and
// blinks move.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { RoomEnvironment } from 'three/addons/environments/RoomEnvironment.js';
import { Rig, MODES } from './rig.js';
import { Face, blinkCurve, BLINK_MS } from './face.js';
import { Wrinkles } from './wrinkles.js';
import { EyeModel, LiveEyes } from './eyes.js';
import { EyeShader } from './eyes_gpu.js';
import { corneaMaterial } from './cornea.js';
import { Sss } from './sss.js';

// Where the export lives: ?data=URL, else the `data/` that `derma view` serves beside the viewer.
const base = (new URLSearchParams(location.search).get('data') ?? 'data').replace(/\/?$/, '/');

// What a script (the browser test, a user's console) can ask the viewer.
const api = {
  ready: false,
  errors: [],
  targets: [],
  units: () => {
    face?.apply();
    return face?.units ?? {};
  },
  // sRGB bytes of the rig's evaluated albedo around (u, v) (v up, as manifest.json's regions).
  colorAt: (u, v) => {
    if (!rig) return null;
    refresh();
    return rig.colorAt(renderer, u, v);
  },
  // The whole evaluated albedo as a PNG data URL (rows from the top, as the texture files).
  albedo: () => {
    if (!rig) return null;
    refresh();
    return rig.toDataURL(renderer);
  },
  // ∛(H / H_max) of the evaluated rig around (u, v): the hemoglobin display mode's value.
  hemoglobinAt: (u, v) => {
    if (!rig) return null;
    const mode = rig.mode;
    rig.mode = MODES.hemoglobin;
    dirty = true;
    refresh();
    const c = rig.colorAt(renderer, u, v, 0);
    rig.mode = mode;
    dirty = true;
    refresh();
    // The render target stores sRGB bytes: decode to the linear value the shader wrote.
    const x = c[0] / 255;
    return x <= 0.04045 ? x / 12.92 : ((x + 0.055) / 1.055) ** 2.4;
  },
  // The skin's normal map with the expression wrinkles of the current face units, as a PNG
  // data URL (rows from the top, as the texture files); null without wrinkle maps.
  wrinkleNormal: () => {
    if (!wrinkles) return null;
    face.apply();
    wrinkles.evaluate(renderer, face.units);
    return wrinkles.toDataURL(renderer);
  },
  // The eye model's port against derma's evaluator: largest distance (mm) over the export's
  // check poses; null without a model.
  eyeCheck: () => eyes?.check() ?? null,
  // Milliseconds per eye-model frame in this browser (the mean of `n` frames at moving gazes),
  // over the first `share` of the region's vertices (how the cost grows with them).
  eyeFrameMs: (n = 20, share = 1) => {
    if (!eyes) return null;
    const m = eyes.model;
    const all = m.n;
    m.n = Math.round(share * all);
    const t0 = performance.now();
    for (let i = 0; i < n; i++) m.evaluate([10 * Math.sin(i), 10 * Math.cos(i)], 0, {});
    const ms = (performance.now() - t0) / n;
    m.n = all;
    eyes.key = '';
    return ms;
  },
  // Milliseconds of JavaScript a frame spends posing the eye region (the mean of `n` poses at
  // moving gazes): the whole model in JavaScript, or only the pose and the lashes' anchors with
  // the model in the vertex shader.
  eyeApplyMs: (n = 20, gpu = true) => {
    if (!eyes) return null;
    const was = eyes.onGpu;
    eyes.onGpu = gpu && !!eyes.gpu;
    const t0 = performance.now();
    for (let i = 0; i < n; i++) eyes.apply([10 * Math.sin(i), 10 * Math.cos(i)], 0, face.units);
    const ms = (performance.now() - t0) / n;
    eyes.onGpu = was;
    eyes.key = '';
    return ms;
  },
  // Canvas pixel (x, y from the top-left) of the upper lid of eye `e` (0 left, 1 right) as last
  // posed, at fraction `t` of its margin from the inner canthus.
  upperLidPixel: (e = 0, t = 0.5) => {
    if (!eyes) return null;
    face.apply();
    eyes.apply(face.gaze, 0, face.units);
    camera.updateMatrixWorld();
    const chain = eyes.model.h.margins[e][0];
    const p = new THREE.Vector3(...eyes.vertex(chain[Math.round(t * (chain.length - 1))])).project(camera);
    return [((p.x + 1) / 2) * canvas.clientWidth, ((1 - p.y) / 2) * canvas.clientHeight];
  },
  // Frames the eyes: the camera in front of the globes' midpoint, `span` metres across the view.
  lookAtEyes: (span = 0.09) => {
    if (!eyes) return false;
    const [l, r] = eyes.model.h.centres;
    const c = new THREE.Vector3(...l.map((x, i) => (0.0005 * (x + r[i]))));
    const dist = span / camera.aspect / (2 * Math.tan((camera.fov * Math.PI) / 360));
    camera.position.set(c.x, c.y, c.z + dist);
    controls.target.copy(c);
    controls.update();
    return true;
  },
  frameFace: () => frameFace(),
  // The eye model in the skin's vertex shader (true) or in JavaScript (false); returns the state.
  eyesOnGpu: (on) => {
    if (!eyes) return null;
    eyes.onGpu = on && !!eyes.gpu;
    return eyes.onGpu;
  },
  // Screen-space subsurface scattering of the skin on or off (sss.js); returns its state.
  setSss: (on) => {
    sss.enabled = on;
    return sss.enabled;
  },
  // The lacrimal lake (lake.js) on or off; returns its state (false without the export's lake).
  setLake: (on) => {
    sss.lake.enabled = on && sss.lake.uniforms.maxSearch.value > 0;
    return sss.lake.enabled;
  },
  // Milliseconds a frame over `n` frames drawn back to back (the eye model, the wrinkles and the
  // SSS as the frame loop runs them), the GPU finished after each.
  frameMs: (n = 20) => {
    const gl = renderer.getContext();
    const px = new Uint8Array(4);
    const t0 = performance.now();
    for (let i = 0; i < n; i++) {
      face.gaze[0] = 10 * Math.sin(i);
      face.apply();
      eyes?.apply(face.gaze, 0, face.units);
      wrinkles?.evaluate(renderer, face.units);
      sss.render(scene, camera, skin);
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    }
    face.gaze[0] = Number(document.getElementById('gaze-yaw')?.value ?? 0);
    return (performance.now() - t0) / n;
  },
  // The globes' materials: refraction through the cornea and the tear film's gloss.
  eyeShading: () =>
    (face?.eyes ?? []).map((p) => {
      const m = p.getObjectByProperty('isMesh', true).material;
      return { cornea: !!m.userData.cornea, ior: m.ior, roughness: m.roughness };
    }),
  // The idle track as the viewer plays it, sampled at 100 Hz over its length: its blinks (the
  // closure crossing 0.3 upward), their mean interval (s) and the table's at its activity.
  idleBlinks: () => {
    if (!motion) return null;
    const onsets = [];
    let last = 0;
    for (let t = 0; t < motion.seconds; t += 0.01) {
      const c = idleAt(t)[2];
      if (last < 0.3 && c >= 0.3) onsets.push(t);
      last = c;
    }
    const mean = (onsets[onsets.length - 1] - onsets[0]) / (onsets.length - 1);
    return { blinks: onsets.length, meanInterval: mean, table: 60 / motion.perMinute, activity: motion.activity };
  },
  // The globes' pupil morphs (the GLB's pupilDilate / pupilConstrict) as last set.
  pupil: () => {
    const out = {};
    for (const n of ['eye_left', 'eye_right']) {
      const o = skin?.parent.getObjectByName(n);
      const dict = o?.morphTargetDictionary;
      if (dict) out[n] = Object.fromEntries(Object.entries(dict).map(([k, i]) => [k, o.morphTargetInfluences[i]]));
    }
    return out;
  },
  // The hair cards' materials as three.js loaded them (the GLB's alphaMode): blended cards are
  // transparent with no alpha test.
  hairMaterials: () => {
    const out = [];
    skin?.parent.traverse((o) => {
      if (o.isMesh && /lash|brow/.test(o.name)) {
        const m = o.material;
        out.push({ name: o.name, transparent: m.transparent, alphaTest: m.alphaTest, depthWrite: m.depthWrite });
      }
    });
    return out;
  },
  regions: {},
  setWeight: (name, w) => setWeight(name, w),
};
window.derma = api;

const status = document.getElementById('status');
function fail(e) {
  console.error(e);
  api.errors.push(String(e.message ?? e));
  status.textContent = `error: ${e.message ?? e}`;
  status.classList.add('error');
}

const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
renderer.toneMapping = THREE.ACESFilmicToneMapping;
renderer.toneMappingExposure = 1.0;
renderer.outputColorSpace = THREE.SRGBColorSpace;

const sss = new Sss(renderer);

const scene = new THREE.Scene();
scene.background = new THREE.Color(0x0d0e12);
const pmrem = new THREE.PMREMGenerator(renderer);
scene.environment = pmrem.fromScene(new RoomEnvironment(), 0.04).texture;
scene.environmentIntensity = 0.55;
// Key light high on the subject's right, a cool fill on the left (three-point portrait setup).
const key = new THREE.DirectionalLight(0xfff1e0, 2.2);
key.position.set(-0.6, 0.8, 1.0);
scene.add(key);
const fill = new THREE.DirectionalLight(0xdde8ff, 0.45);
fill.position.set(1.0, 0.2, 0.6);
scene.add(fill);

const camera = new THREE.PerspectiveCamera(28, 1, 0.01, 10);
const controls = new OrbitControls(camera, canvas);
controls.enableDamping = true;

let rig = null;
let wrinkles = null;
let face = null;
let eyes = null;
let skin = null;
const original = {};
let dirty = true;
let blinkStart = -1;
// The idle eyes (manifest.eyes.motion, derma-eyes' models): frames of gaze and lid closure, and
// when their playing started (0: not playing).
let motion = null;
let idleStart = 0;

/** The idle track at `t` s (looped): [gaze h°, gaze v°, closure], linear between frames. */
function idleAt(t) {
  const { fps, seconds, frames } = motion;
  const f = ((t % seconds) + seconds) % seconds * fps;
  const i = Math.floor(f);
  const j = Math.min(i + 1, frames.length / 3 - 1);
  const r = f - i;
  return [0, 1, 2].map((k) => frames[3 * i + k] * (1 - r) + frames[3 * j + k] * r);
}

function resize() {
  const w = canvas.clientWidth;
  const h = canvas.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);

function setWeight(name, w) {
  if (!rig || !(name in rig.weights)) throw new Error(`no rig target '${name}'`);
  rig.weights[name] = w;
  face.setExpression({ ...rig.weights });
  const el = document.getElementById(`w-${name}`);
  if (el) el.value = String(w);
  dirty = true;
}

// ---- controls ----
const panel = document.getElementById('panel');
// The pupil `mm` across through the globes' morphs: the texture's own is 4 mm, pupilDilate
// draws 8 and pupilConstrict 2 (derma-head's eye::PUPIL_MORPHS_MM); between, linearly.
let pupilMm = 4;
function setPupil(mm) {
  pupilMm = mm;
  for (const n of ['eye_left', 'eye_right']) {
    const o = skin?.parent.getObjectByName(n);
    const dict = o?.morphTargetDictionary;
    if (!dict || !('pupilDilate' in dict)) continue;
    o.morphTargetInfluences[dict.pupilDilate] = Math.max(0, (mm - 4) / 4);
    o.morphTargetInfluences[dict.pupilConstrict] = Math.max(0, (4 - mm) / 2);
  }
}

function slider(parent, id, label, min, max, step, value, onInput) {
  const row = document.createElement('label');
  row.className = 'row';
  const span = document.createElement('span');
  span.textContent = label;
  const input = document.createElement('input');
  Object.assign(input, { type: 'range', id, min, max, step, value });
  const out = document.createElement('output');
  out.textContent = Number(value).toFixed(2);
  input.addEventListener('input', () => {
    out.textContent = Number(input.value).toFixed(2);
    onInput(Number(input.value));
  });
  row.append(span, input, out);
  parent.append(row);
  return input;
}
function checkbox(parent, id, label, checked, onChange) {
  const row = document.createElement('label');
  row.className = 'row check';
  const input = document.createElement('input');
  Object.assign(input, { type: 'checkbox', id, checked });
  input.addEventListener('change', () => onChange(input.checked));
  row.append(input, document.createTextNode(label));
  parent.append(row);
  return input;
}
function section(title) {
  const s = document.createElement('fieldset');
  const l = document.createElement('legend');
  l.textContent = title;
  s.append(l);
  panel.append(s);
  return s;
}

function buildControls() {
  if (rig) {
    const s = section('Expression (skin appearance rig)');
    for (const name of rig.targets) {
      slider(s, `w-${name}`, name, 0, 1, 0.01, 0, (v) => setWeight(name, v));
    }
    const g = slider(s, 'global-scale', 'global blood ×', 0.5, 1.5, 0.01, 1, (v) => {
      rig.globalScale = auto.checked ? 'auto' : v;
      dirty = true;
    });
    const auto = checkbox(s, 'global-auto', 'global scale from the expressions (auto)', true, (on) => {
      rig.globalScale = on ? 'auto' : Number(g.value);
      dirty = true;
    });
    checkbox(s, 'pose', 'pose the face with the expression', true, (on) => {
      face.poseExpressions = on;
    });
  } else {
    const s = section('Expression');
    s.append('No rig in this export (derma export web --rig DIR); showing base_color.png.');
  }
  const e = section('Eyes');
  slider(e, 'gaze-yaw', 'gaze yaw °', -35, 35, 0.5, 0, (v) => (face.gaze[0] = v));
  slider(e, 'gaze-pitch', 'gaze pitch °', -30, 25, 0.5, 0, (v) => (face.gaze[1] = v));
  slider(e, 'aperture', 'aperture', -1, 1, 0.01, 0, (v) => (face.aperture = v));
  slider(e, 'pupil', 'pupil mm', 2, 8, 0.1, 4, (v) => setPupil(v));
  const b = document.createElement('button');
  b.id = 'blink';
  b.textContent = 'blink';
  b.addEventListener('click', () => (blinkStart = performance.now()));
  e.append(b);
  if (eyes) checkbox(e, 'eye-model', 'lids from the trained eye-region model (off: face units)', true, (on) => (eyes.enabled = on));
  if (eyes?.gpu) checkbox(e, 'eye-gpu', 'eye model in the vertex shader (off: JavaScript)', true, (on) => api.eyesOnGpu(on));
  if (motion) {
    checkbox(e, 'idle', `eyes on their own (derma-eyes: blinks at ${motion.perMinute.toFixed(0)}/min as table 3.1 draws them, idle saccades on the main sequence)`, false, (on) => {
      idleStart = on ? performance.now() : 0;
      if (!on) {
        // Back to the sliders' gaze.
        face.gaze[0] = Number(document.getElementById('gaze-yaw').value);
        face.gaze[1] = Number(document.getElementById('gaze-pitch').value);
      }
    });
  }

  const m = section('Maps');
  const select = document.createElement('select');
  select.id = 'display';
  for (const [v, t] of [
    ['shaded', 'shaded'],
    ['albedo', 'albedo (unlit)'],
    ['hemoglobin', 'hemoglobin ∛(H / H_max)'],
    ['melanin', 'melanin ∛(C_m / C_m,max)'],
    ['normal', 'normal map'],
  ]) {
    if (!rig && (v === 'hemoglobin' || v === 'melanin')) continue;
    const o = document.createElement('option');
    o.value = v;
    o.textContent = t;
    select.append(o);
  }
  select.addEventListener('change', () => setDisplay(select.value));
  m.append(select);
  if (rig) checkbox(m, 'map-rig', 'albedo from the rig (off: base_color.png)', true, (on) => setMap('map', on ? rig.target.texture : original.map));
  checkbox(m, 'sss', 'subsurface scattering (screen space, Jimenez et al. 2015)', true, (on) => (sss.enabled = on));
  if (sss.lake.enabled) checkbox(m, 'lake', 'lacrimal lake (the tear meniscus, EyeMove §4.5)', true, (on) => api.setLake(on));
  checkbox(m, 'map-normal', 'normal map', true, (on) => setMap('normalMap', on ? original.normalMap : null));
  checkbox(m, 'map-rough', 'roughness and specular maps', true, (on) => {
    setMap('roughnessMap', on ? original.roughnessMap : null);
    setMap('specularIntensityMap', on ? original.specularIntensityMap : null);
    if (!on) skin.material.roughness = 0.45;
    else skin.material.roughness = original.roughness;
  });
  checkbox(m, 'parts', 'eyes, lashes, teeth', true, (on) => {
    for (const n of ['eye_left_pivot', 'eye_right_pivot', 'eyelashes_left', 'eyelashes_right', 'teeth_upper', 'teeth_lower', 'tongue']) {
      const o = skin.parent.getObjectByName(n);
      if (o) o.visible = on;
    }
  });
}

function refresh() {
  if (rig && dirty) {
    rig.evaluate(renderer);
    dirty = false;
  }
}

function setMap(slot, tex) {
  skin.material[slot] = tex;
  skin.material.needsUpdate = true;
}

const flat = new THREE.MeshBasicMaterial();
function setDisplay(mode) {
  if (mode === 'shaded') {
    skin.material = original.material;
  } else {
    flat.map = mode === 'normal' ? original.normalMap : rig ? rig.target.texture : original.map;
    flat.needsUpdate = true;
    skin.material = flat;
  }
  if (rig) {
    rig.mode = mode === 'hemoglobin' ? MODES.hemoglobin : mode === 'melanin' ? MODES.melanin : MODES.color;
    dirty = true;
  }
}

// Frames the face: the skin's bounds, seen from the front a little above eye level.
function frameFace() {
  const box = new THREE.Box3().setFromObject(skin);
  const c = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3());
  const dist = (0.9 * size.y) / (2 * Math.tan((camera.fov * Math.PI) / 360));
  camera.position.set(c.x, c.y + 0.05 * size.y, c.z + dist);
  camera.near = dist / 20;
  camera.far = dist * 20;
  camera.updateProjectionMatrix();
  controls.target.copy(c);
  controls.update();
}

// ---- loading ----
async function load() {
  const res = await fetch(base + 'manifest.json');
  if (!res.ok) throw new Error(`${base}manifest.json: HTTP ${res.status} (expected a \`derma export web\` directory)`);
  const manifest = await res.json();
  if (manifest.format !== 'derma-web') throw new Error(`${base}manifest.json: format '${manifest.format}', expected 'derma-web'`);
  api.regions = manifest.regions ?? {};
  const gltf = await new GLTFLoader().loadAsync(base + manifest.glb);
  scene.add(gltf.scene);
  skin = gltf.scene.getObjectByName(manifest.skin_mesh);
  if (!skin) throw new Error(`${manifest.glb}: no mesh named '${manifest.skin_mesh}'`);
  if (!skin.isMesh) skin = skin.getObjectByProperty('isMesh', true);
  const mat = skin.material;
  Object.assign(original, {
    material: mat,
    map: mat.map,
    normalMap: mat.normalMap,
    roughnessMap: mat.roughnessMap,
    specularIntensityMap: mat.specularIntensityMap ?? null,
    roughness: mat.roughness,
  });
  const centres = manifest.eyes?.centres.map((c) => c.map((x) => x * 0.001));
  face = new Face(gltf.scene, manifest.expression_units ?? {}, centres);
  // The globes drawn as derma render draws them: refraction, the pupil, the wet tear film.
  for (const pivot of face.eyes) {
    const mesh = pivot.getObjectByProperty('isMesh', true);
    const b = mesh.geometry.boundingBox;
    corneaMaterial(mesh, pivot, (b.max.x - b.min.x) / 2, () => pupilMm);
  }
  if (manifest.eyes) {
    status.textContent = 'loading the eye model…';
    const model = await EyeModel.load(base, manifest.eyes);
    const gpu = new EyeShader(model, skin);
    for (const m of [mat, flat]) gpu.patch(m);
    eyes = new LiveEyes(model, skin, gltf.scene, face.eyes, gpu);
    if (manifest.eyes.lake) sss.lake.configure(manifest.eyes.lake);
    const m = manifest.eyes.motion;
    if (m) {
      const res = await fetch(base + m.file);
      if (!res.ok) throw new Error(`${base}${m.file}: HTTP ${res.status}`);
      motion = { fps: m.fps, seconds: m.seconds, activity: m.activity, perMinute: m.blinks_per_minute, frames: new Float32Array(await res.arrayBuffer()) };
    }
  }
  if (manifest.wrinkles && mat.normalMap) {
    wrinkles = await Wrinkles.load(base, manifest, mat.normalMap);
    wrinkles.evaluate(renderer, {});
    original.normalMap = mat.normalMap = wrinkles.target.texture;
    mat.needsUpdate = true;
  }
  if (manifest.rig) {
    status.textContent = 'loading the rig…';
    rig = await Rig.load(base, manifest);
    api.targets = rig.targets;
    rig.evaluate(renderer);
    mat.map = rig.target.texture;
    mat.needsUpdate = true;
  }
  frameFace();
  buildControls();
  status.textContent = `${manifest.glb}: ${rig ? rig.targets.length + ' rig targets' : 'no rig'}, ${face.unitNames().length} face units${wrinkles ? ', expression wrinkles' : ''}${eyes ? ', eye model' : ''}`;
  api.ready = true;
}

function frame(now) {
  requestAnimationFrame(frame);
  if (!face) return;
  const t = blinkStart >= 0 ? now - blinkStart : -1;
  face.blink = blinkCurve(t);
  if (t > BLINK_MS.down + BLINK_MS.up) blinkStart = -1;
  if (idleStart && motion) {
    const [h, v, closure] = idleAt((now - idleStart) / 1000);
    face.gaze[0] = h;
    face.gaze[1] = v;
    face.blink = Math.max(face.blink, closure);
  }
  face.apply();
  eyes?.apply(face.gaze, 0, face.units);
  wrinkles?.evaluate(renderer, face.units);
  refresh();
  controls.update();
  sss.render(scene, camera, skin);
  api.frames = (api.frames ?? 0) + 1;
}

resize();
requestAnimationFrame(frame);
load().catch(fail);
