// The head's motion in the viewer: ARKit face units (the GLB's morph targets) posing each rig
// expression, gaze (eye rotation with the lids following through eyeLook* units) and blinks.
import * as THREE from 'three';

/**
 * Eye rotation (degrees) at which an eyeLook* unit reaches weight 1: ±35° horizontally, 25° up,
 * 30° down — authored to the oculomotor range used in everyday gaze (most saccades stay within
 * ±15°, Bahill et al. 1975), so the lids track comfortably over the sliders' range.
 */
const LOOK_RANGE = { horizontal: 35, up: 25, down: 30 };

/** A spontaneous blink of mean amplitude (derma-eyes' blink model, thesis §3.9): the down
 * phase 66 ms (Evinger et al. 1991), the up phase 1.435 times longer (Sforza et al. 2008), each
 * on the minimum-jerk profile (Flash & Hogan 1985). */
export const BLINK_MS = { down: 66, up: 66 * 1.435 };

const minJerk = (x) => x * x * x * (10 + x * (-15 + 6 * x));

/** Lid closure (0–1) `t` ms into that blink. */
export function blinkCurve(t) {
  const { down, up } = BLINK_MS;
  if (t < 0 || t >= down + up) return 0;
  if (t < down) return minJerk(t / down);
  return 1 - minJerk((t - down) / up);
}

/**
 * The head's animated parts: meshes with face units, and the eyes on pivots at their centres.
 * `expressionUnits`: the face units posing each rig expression at full weight (manifest.json's
 * `expression_units`, from derma-rig's expression library); `centres`: the globe centres (m,
 * left then right) where the export knows them (its eye model), else found from each globe.
 */
export class Face {
  constructor(root, expressionUnits = {}, centres = null) {
    this.expressionUnits = expressionUnits;
    this.morphed = [];
    this.eyes = [];
    root.traverse((o) => {
      // The face units' meshes (the globes' pupil morphs are the pupil slider's).
      if (o.isMesh && o.morphTargetDictionary && !('pupilDilate' in o.morphTargetDictionary)) this.morphed.push(o);
    });
    for (const name of ['eye_left', 'eye_right']) {
      const eye = root.getObjectByName(name);
      if (!eye) continue;
      const mesh = eye.isMesh ? eye : eye.getObjectByProperty('isMesh', true);
      mesh.geometry.computeBoundingBox();
      const b = mesh.geometry.boundingBox;
      // The globe's centre: mid-box across, one radius behind the back of the globe's front
      // (the cornea bulges forward along +Z, so the box centre would sit in front of it).
      const r = (b.max.x - b.min.x) / 2;
      const c = centres
        ? new THREE.Vector3(...centres[this.eyes.length])
        : new THREE.Vector3((b.min.x + b.max.x) / 2, (b.min.y + b.max.y) / 2, b.min.z + r);
      const pivot = new THREE.Group();
      pivot.name = `${name}_pivot`;
      pivot.position.copy(c);
      if (!centres) pivot.position.applyMatrix4(eye.matrix);
      eye.parent.add(pivot);
      pivot.add(eye);
      eye.position.sub(c);
      this.eyes.push(pivot);
    }
    this.units = {};
    this.expression = {};
    this.gaze = [0, 0];
    this.aperture = 0;
    this.blink = 0;
    this.poseExpressions = true;
  }

  /** Names of the face units the GLB carries. */
  unitNames() {
    return this.morphed.length ? Object.keys(this.morphed[0].morphTargetDictionary) : [];
  }

  /** Rig expression weights by name (posing the face when `poseExpressions`). */
  setExpression(weights) {
    this.expression = weights;
  }

  /** Face-unit weights from expressions, gaze, aperture and blink, then applied. */
  apply() {
    const u = {};
    const add = (n, w) => (u[n] = Math.min((u[n] ?? 0) + w, 1));
    if (this.poseExpressions) {
      for (const [e, w] of Object.entries(this.expression)) {
        for (const [n, k] of Object.entries(this.expressionUnits[e] ?? {})) add(n, w * k);
      }
    }
    // Gaze: positive yaw to the subject's left (+X), positive pitch up.
    const [yaw, pitch] = this.gaze;
    const h = Math.min(Math.abs(yaw) / LOOK_RANGE.horizontal, 1);
    if (yaw > 0) {
      add('eyeLookOutLeft', h);
      add('eyeLookInRight', h);
    } else if (yaw < 0) {
      add('eyeLookInLeft', h);
      add('eyeLookOutRight', h);
    }
    if (pitch > 0) {
      const v = Math.min(pitch / LOOK_RANGE.up, 1);
      add('eyeLookUpLeft', v);
      add('eyeLookUpRight', v);
    } else if (pitch < 0) {
      const v = Math.min(-pitch / LOOK_RANGE.down, 1);
      add('eyeLookDownLeft', v);
      add('eyeLookDownRight', v);
    }
    // Aperture: above zero the lids open wide, below they close; a blink closes them fully.
    const close = Math.max(-this.aperture, 0);
    const wide = Math.max(this.aperture, 0);
    for (const s of ['Left', 'Right']) {
      add(`eyeWide${s}`, wide * (1 - this.blink));
      u[`eyeBlink${s}`] = Math.max(close, this.blink);
    }
    this.units = u;
    for (const m of this.morphed) {
      const d = m.morphTargetDictionary;
      m.morphTargetInfluences.fill(0);
      for (const [n, w] of Object.entries(u)) if (d[n] !== undefined) m.morphTargetInfluences[d[n]] = w;
    }
    for (const p of this.eyes) p.rotation.set((-pitch * Math.PI) / 180, (yaw * Math.PI) / 180, 0, 'YXZ');
  }
}
