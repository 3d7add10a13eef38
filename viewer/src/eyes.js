// The trained eye-region model live (EyeMove thesis §3.9, fig. 3.14 and Algorithm 1): g̃ from
// gaze, lid closure and the face units → e = W g̃ → ũ⁺ = Ũ e → the lids' contact → depth and
// normals linear in e → globe sliding, as derma_eyes::evaluate does, on the arrays
// `derma export web` writes (eyes/model.bin).

const DEG = Math.PI / 180;
const sign = (x) => (x >= 0 ? 1 : -1); // glam's signum: +0 → +1

/** The polyline [[x, y]…]'s height at x (linear between its points; null outside it). */
function heightAt(chain, x) {
  for (let j = 0; j + 1 < chain.length; j++) {
    const [[ax, ay], [bx, by]] = [chain[j], chain[j + 1]];
    const [lo, hi] = [Math.min(ax, bx), Math.max(ax, bx)];
    if (x >= lo && x <= hi && hi > lo) return ay + ((by - ay) * (x - ax)) / (bx - ax);
  }
  return null;
}

/** Rotation matrix (row-major 3×3) of Fick angles (h, v): R = R_Y(h) · R_X(−v). */
function fick(h, v) {
  const [ch, sh, cv, sv] = [Math.cos(h * DEG), Math.sin(h * DEG), Math.cos(-v * DEG), Math.sin(-v * DEG)];
  return [ch, sh * sv, sh * cv, 0, cv, -sv, -sh, ch * sv, ch * cv];
}

export class EyeModel {
  constructor(header, bin) {
    if (header.version !== 2) throw new Error(`eyes/model.bin: layout version ${header.version}; this viewer reads version 2 (export the set again)`);
    this.h = header;
    const arr = (name) => {
      const a = header.arrays[name];
      if (!a) throw new Error(`eyes/model.bin: no array '${name}'`);
      const Type = a.type === 'u32' ? Uint32Array : Float32Array;
      if (a.offset + 4 * a.count * a.components > bin.byteLength) throw new Error(`eyes/model.bin: array '${name}' past the end of the file`);
      return new Type(bin, a.offset, a.count * a.components);
    };
    for (const n of ['basis', 'depth', 'lift', 'offset', 'normal_offset', 'rest', 'rest_normals', 'eye', 'slide', 'radial', 'skin_vertices']) this[n] = arr(n);
    this.lashAnchors = Object.fromEntries(header.lashes.map((l) => [l.name, arr(l.anchors)]));
    this.n = header.vertices;
    this.k = header.k;
    this.pos = new Float32Array(3 * this.n);
    this.nrm = new Float32Array(3 * this.n);
    this.angles = [
      [0, 0],
      [0, 0],
    ];
    this.pose([0, 0], 0, {});
  }

  static async load(base, entry) {
    const res = await fetch(base + entry.file);
    if (!res.ok) throw new Error(`${base}${entry.file}: HTTP ${res.status}`);
    return new EyeModel(entry, await res.arrayBuffer());
  }

  /** g̃ for gaze (yaw, pitch)° of the cyclopean eye, lid closure and face units by name. */
  inputs(gaze, closure, units) {
    const h = this.h;
    const c = h.centres;
    const mid = [0, 1, 2].map((i) => 0.5 * (c[0][i] + c[1][i]));
    const [yh, yv] = [gaze[0] * DEG, gaze[1] * DEG];
    const dir = [Math.sin(yh) * Math.cos(yv), Math.sin(yv), Math.cos(yh) * Math.cos(yv)];
    const target = mid.map((m, i) => m + h.fixation_mm * dir[i]);
    const w = (name) => Math.min(Math.max(units[name] ?? 0, 0), 1);
    const g = [];
    for (let e = 0; e < 2; e++) {
      const d = target.map((t, i) => t - c[e][i]);
      const len = Math.hypot(...d);
      const eh = Math.atan2(d[0], d[2]) / DEG;
      const ev = Math.asin(Math.min(Math.max(d[1] / len, -1), 1)) / DEG;
      this.angles[e] = [eh, ev];
      const side = e === 0 ? 'Left' : 'Right';
      const ce = Math.min(Math.max(Math.max(closure, w(`eyeBlink${side}`)), 0), 1);
      const wide = w(`eyeWide${side}`) * (1 - ce);
      const f = [eh, Math.abs(eh), Math.max(ev, 0), Math.min(ev, 0), 1];
      const lids = h.baseline.rows[e].map((row) => {
        const b = (1 - ce) * row.reduce((s, x, i) => s + x * f[i], 0);
        return b + wide * (1 - b);
      });
      g.push(eh, ev, 0, lids[0], lids[1]);
    }
    for (const u of h.units) g.push(w(u));
    return g;
  }

  /**
   * The pose's per-frame quantities: the latent e = W g̃, each globe's angles and rotation, and
   * each eye's lid contact (where its upper margin falls below the lower, by how much along x;
   * null where it does not). Everything per vertex then follows from these ([`vertexAt`]), here
   * or in the vertex shader (eyes_gpu.js).
   */
  pose(gaze, closure, units) {
    const g = this.inputs(gaze, closure, units);
    this.e = this.h.w.map((row) => row.reduce((s, x, i) => s + x * (i < g.length ? g[i] : 1), 0));
    this.rot = this.angles.map(([h, v]) => fick(h, v));
    this.short = this.contact();
  }

  /** ũ⁺ of vertex i before the lids' contact: the basis' mean plus Σ e_j times its columns. */
  basisAt(i) {
    const { basis, k, e } = this;
    const s = i * 2 * (k + 1);
    let [x, y] = [basis[s], basis[s + 1]];
    for (let j = 0; j < k; j++) {
      x += e[j] * basis[s + 2 + 2 * j];
      y += e[j] * basis[s + 3 + 2 * j];
    }
    return [x, y];
  }

  /** Model-vertex positions and normals (mm) into this.pos / this.nrm: of all the vertices, or
   * of the listed ones only. */
  evaluate(gaze, closure, units, vertices = null) {
    this.pose(gaze, closure, units);
    if (vertices) for (const i of vertices) this.vertexAt(i);
    else for (let i = 0; i < this.n; i++) this.vertexAt(i);
  }

  /** Vertex i's position and normal for the current pose. */
  vertexAt(i) {
    const { offset, normal_offset: noff, pos, nrm, lift } = this;
    let [x, y] = this.basisAt(i);
    const short = this.short[this.eye[i]];
    if (short && lift[i] > 0) y += lift[i] * (heightAt(short, x) ?? 0);
    // Depth and normal, each linear in e: [value at e = 0, k columns] × (z, n_x, n_y, n_z).
    const k1 = this.h.depth.k + 1;
    const b = 4 * k1 * i;
    const n = [this.linearAt(b + k1), this.linearAt(b + 2 * k1), this.linearAt(b + 3 * k1)];
    const p = [x, y, this.linearAt(b)];
    let nl = Math.hypot(n[0], n[1], n[2]);
    const m = nl > 0 ? n.map((c) => c / nl) : [0, 0, 1];
    for (let q = 0; q < 3; q++) {
      pos[3 * i + q] = p[q] + offset[3 * i + q];
      m[q] += noff[3 * i + q];
    }
    nl = 1 / Math.hypot(m[0], m[1], m[2]);
    for (let q = 0; q < 3; q++) nrm[3 * i + q] = m[q] * nl;
    this.slideAt(i);
  }

  /** A depth-basis value at offset b: its value at e = 0 plus Σ e_j times its columns. */
  linearAt(b) {
    const { depth, e } = this;
    const kd = this.h.depth.k;
    let v = depth[b];
    for (let j = 0; j < kd; j++) v += e[j] * depth[b + 1 + j];
    return v;
  }

  /** The lids' contact: per eye the polyline [[x, shortfall]…] along its upper margin where it
   * falls below the lower (the upper lid is lifted by it, times each vertex's lift), or null. */
  contact() {
    const chain = (c) => c.map((i) => this.basisAt(i));
    return this.h.margins.map(([upperIdx, lowerIdx]) => {
      const [upper, lower] = [chain(upperIdx), chain(lowerIdx)];
      const short = upper.map(([x, y], j) => {
        const h = heightAt(lower, x);
        const inner = j > 0 && j + 1 < upper.length;
        return [x, inner && h !== null ? Math.max(h - y, 0) : 0];
      });
      return short.every(([, s]) => s === 0) ? null : short;
    });
  }

  /** D(dir): the globe's radial distance along a unit direction of its own frame (bilinear). */
  radius(eye, x, y, z) {
    const size = this.h.radial.size;
    const l1 = Math.abs(x) + Math.abs(y) + Math.abs(z);
    let px = x / l1;
    let py = y / l1;
    if (z < 0) {
      const qx = (1 - Math.abs(py)) * sign(px);
      py = (1 - Math.abs(px)) * sign(py);
      px = qx;
    }
    const fx = Math.min(Math.max((px * 0.5 + 0.5) * size - 0.5, 0), size - 1 - 1e-3);
    const fy = Math.min(Math.max((py * 0.5 + 0.5) * size - 0.5, 0), size - 1 - 1e-3);
    const x0 = Math.floor(fx);
    const y0 = Math.floor(fy);
    const tx = fx - x0;
    const ty = fy - y0;
    const r = this.radial;
    const i = eye * size * size + y0 * size + x0;
    const top = r[i] + (r[i + 1] - r[i]) * tx;
    const bot = r[i + size] + (r[i + size + 1] - r[i + size]) * tx;
    return top + (bot - top) * ty;
  }

  /** Algorithm 1: vertex i, where it is skin inside its globe (in the globe's current
   * orientation), pushed out to the globe's surface. */
  slideAt(i) {
    const { pos, nrm, slide, eye: eyeOf, rest_normals: rn } = this;
    const reach = this.h.radial.reach;
    const c = this.h.centres;
    const s = 6 * i;
    const kind = slide[s];
    if (kind < 0) return;
    const t = slide[s + 1];
    const e = eyeOf[i];
    const R = this.rot[e];
    const [cx, cy, cz] = c[e];
    const qx = pos[3 * i] - cx;
    const qy = pos[3 * i + 1] - cy;
    const qz = pos[3 * i + 2] - cz;
    // Into the globe's frame (Rᵀ).
    const rx = R[0] * qx + R[3] * qy + R[6] * qz;
    const ry = R[1] * qx + R[4] * qy + R[7] * qz;
    const rz = R[2] * qx + R[5] * qy + R[8] * qz;
    const len = Math.max(Math.sqrt(rx * rx + ry * ry + rz * rz), 1e-6);
    if (kind === 0 && len >= reach[e] + t) return;
    const dx = rx / len;
    const dy = ry / len;
    const dz = rz / len;
    // Back to head space: τ = R · dir.
    const tx = R[0] * dx + R[1] * dy + R[2] * dz;
    const ty = R[3] * dx + R[4] * dy + R[5] * dz;
    const tz = R[6] * dx + R[7] * dy + R[8] * dz;
    if (kind === 0) {
      const delta = this.radius(e, dx, dy, dz) + t;
      if (delta > len) {
        pos[3 * i] = cx + tx * delta;
        pos[3 * i + 1] = cy + ty * delta;
        pos[3 * i + 2] = cz + tz * delta;
        nrm[3 * i] = tx;
        nrm[3 * i + 1] = ty;
        nrm[3 * i + 2] = tz;
      }
    } else {
      const delta = this.radius(e, dx, dy, dz) + t + slide[s + 2];
      const nx = rn[3 * i] + tx - slide[s + 3];
      const ny = rn[3 * i + 1] + ty - slide[s + 4];
      const nz = rn[3 * i + 2] + tz - slide[s + 5];
      const nl = 1 / Math.sqrt(nx * nx + ny * ny + nz * nz);
      pos[3 * i] = cx + tx * delta;
      pos[3 * i + 1] = cy + ty * delta;
      pos[3 * i + 2] = cz + tz * delta;
      nrm[3 * i] = nx * nl;
      nrm[3 * i + 1] = ny * nl;
      nrm[3 * i + 2] = nz * nl;
    }
  }

  /** Largest distance (mm) between this port and derma's evaluator over the header's checks. */
  check() {
    let worst = 0;
    for (const p of this.h.checks.poses) {
      this.evaluate(p.gaze, p.closure, p.units);
      this.h.checks.vertices.forEach((v, j) => {
        const d = Math.hypot(...[0, 1, 2].map((q) => this.pos[3 * v + q] - p.positions[j][q]));
        worst = Math.max(worst, d);
      });
    }
    return worst;
  }
}

/**
 * The model bound to the scene: the skin's region vertices posed by it (the model's positions
 * replacing the face units' inside the region, as derma render composes them) — in the skin's
 * vertex shader (eyes_gpu.js) or, with `gpu` null or `onGpu` false, written from JavaScript —
 * the lashes riding on their lid margins, and the globes' verged angles.
 */
export class LiveEyes {
  constructor(model, skin, root, pivots, gpu = null) {
    this.model = model;
    this.skin = skin;
    this.pivots = pivots;
    this.gpu = gpu;
    this.onGpu = !!gpu;
    this.enabled = true;
    const geo = skin.geometry;
    this.restPos = geo.attributes.position.array.slice();
    this.restNrm = geo.attributes.normal.array.slice();
    this.lashes = Object.entries(model.lashAnchors).flatMap(([name, anchors]) => {
      const o = root.getObjectByName(name);
      const mesh = o && (o.isMesh ? o : o.getObjectByProperty('isMesh', true));
      return mesh ? [{ mesh, anchors, rest: mesh.geometry.attributes.position.array.slice() }] : [];
    });
    this.anchors = [...new Set(this.lashes.flatMap((l) => [...l.anchors]))];
    this.key = '';
    this.written = false;
  }

  /** Poses the region for gaze (yaw, pitch)°, closure and the face units (after Face.apply). */
  apply(gaze, closure, units) {
    const m = this.model;
    // The lashes ride on the model's lid margins, not on the face units.
    if (this.enabled) for (const l of this.lashes) l.mesh.morphTargetInfluences?.fill(0);
    const gpu = this.enabled && this.onGpu;
    const key = this.enabled ? JSON.stringify([gaze, closure, units, gpu]) : 'off';
    if (key === this.key) {
      if (this.enabled) this.turnGlobes();
      return;
    }
    this.key = key;
    this.gpu?.update(m, false);
    if (!this.enabled) {
      this.restore();
      for (const l of this.lashes) l.mesh.geometry.attributes.position.array.set(l.rest);
      for (const l of this.lashes) l.mesh.geometry.attributes.position.needsUpdate = true;
      return;
    }
    if (gpu) {
      m.evaluate(gaze, closure, units, this.anchors);
      this.restore();
      this.gpu.update(m, true);
    } else {
      m.evaluate(gaze, closure, units);
      this.write(units);
    }
    for (const l of this.lashes) {
      const a = l.mesh.geometry.attributes.position;
      for (let j = 0; j < l.anchors.length; j++) {
        const v = l.anchors[j];
        for (let q = 0; q < 3; q++) a.array[3 * j + q] = l.rest[3 * j + q] + (m.pos[3 * v + q] - m.rest[3 * v + q]) * 0.001;
      }
      a.needsUpdate = true;
    }
    this.turnGlobes();
  }

  /** The skin's rest positions and normals back in its buffers (once after JavaScript wrote them). */
  restore() {
    if (!this.written) return;
    const geo = this.skin.geometry;
    geo.attributes.position.array.set(this.restPos);
    geo.attributes.normal.array.set(this.restNrm);
    geo.attributes.position.needsUpdate = geo.attributes.normal.needsUpdate = true;
    this.written = false;
  }

  /** The evaluated region into the skin's buffers, less the region units' morphs that three.js
   * adds on top. */
  write(units) {
    const m = this.model;
    const geo = this.skin.geometry;
    const [P, N] = [geo.attributes.position, geo.attributes.normal];
    const dict = this.skin.morphTargetDictionary;
    const morphs = m.h.region_units
      .filter((u) => (units[u] ?? 0) !== 0 && dict[u] !== undefined)
      .map((u) => [units[u], geo.morphAttributes.position[dict[u]].array]);
    const sv = m.skin_vertices;
    for (let j = 0; j < sv.length; j += 2) {
      const [g, v] = [sv[j], sv[j + 1]];
      for (let q = 0; q < 3; q++) {
        let x = m.pos[3 * v + q] * 0.001;
        for (const [w, d] of morphs) x -= w * d[3 * g + q];
        P.array[3 * g + q] = x;
        N.array[3 * g + q] = m.nrm[3 * v + q];
      }
    }
    P.needsUpdate = N.needsUpdate = true;
    this.written = true;
  }

  /** Each globe to its own (verged) Fick angles. */
  turnGlobes() {
    this.model.angles.forEach(([h, v], e) => this.pivots[e]?.rotation.set(-v * DEG, h * DEG, 0, 'YXZ'));
  }

  /** The port against derma's evaluator (mm); the next apply re-evaluates. */
  check() {
    this.key = '';
    return this.model.check();
  }

  /** Head-space position (m) of model vertex `v` as last posed. */
  vertex(v) {
    this.model.vertexAt(v);
    return [0, 1, 2].map((q) => this.model.pos[3 * v + q] * 0.001);
  }
}
