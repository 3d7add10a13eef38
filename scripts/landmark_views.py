#!/usr/bin/env python3
"""Hand-placed landmarks for the corpus (crates/derma-head/tests/data/corpus_landmarks.json): a
person looks at an orthographic view of a mesh and reads each landmark's pixel off it; this
script draws the view and turns the pixels into points on the mesh. Run by hand (needs numpy,
pillow, trimesh and embreex from PyPI); derma's tests read only the JSON it helped write.

    python3 scripts/landmark_views.py render MESH.obj --up +Y --front +Z --centre=X,Y,Z \
        --width W [--yaw DEG] [--pitch DEG] [--profile] --out VIEW.png
    python3 scripts/landmark_views.py pick VIEW.json nose_tip=512,480 mouth_corner_left=600,700

`render` writes VIEW.png (shaded by normal, 1200 pixels square, W mesh units across, a grid
every 50 pixels labelled every 100) and VIEW.json (the view); `pick` casts a ray from each pixel
along the view and prints the first surface point it meets, in the mesh file's coordinates.
`pick --plane MIDLINE.json:NAME` picks on a profile view instead: the pixel's line of sight meets
the midsagittal plane through the named point of an earlier pick (the nose tip) facing the view,
and the surface point nearest there is taken (glabella and subnasale are read off a profile).
Left and right are the subject's own (the head's left is the viewer's right in a front view).
"""

import argparse
import json
import sys

import numpy as np

RES = 1200


def axis(name):
    sign = -1.0 if name.startswith("-") else 1.0
    v = {"X": [1, 0, 0], "Y": [0, 1, 0], "Z": [0, 0, 1]}[name.strip("+-").upper()]
    return sign * np.array(v, float)


def rot(axis_vec, deg):
    a = np.radians(deg)
    k = axis_vec / np.linalg.norm(axis_vec)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def basis(up, front, yaw, pitch):
    right = np.cross(up, front)
    # Turn the view with the face: yaw about up, then pitch about right.
    r = rot(up, yaw)
    front, right = r @ front, r @ right
    p = rot(right, pitch)
    return right, p @ up, p @ front


def load(path):
    import trimesh

    m = trimesh.load(path, force="mesh", process=False)
    return m


def render(a):
    from PIL import Image, ImageDraw
    import trimesh

    mesh = load(a.mesh)
    right, up, front = basis(axis(a.up), axis(a.front), a.yaw, a.pitch)
    if a.profile:
        # From the subject's right: the face looks to the image's right.
        right, front = front, -right
    centre = np.array([float(x) for x in a.centre.split(",")])
    px = a.width / RES
    ii, jj = np.meshgrid(np.arange(RES), np.arange(RES))
    origins = (centre + ((ii - RES / 2 + 0.5) * px)[..., None] * right
               - ((jj - RES / 2 + 0.5) * px)[..., None] * up + front * 10 * a.width).reshape(-1, 3)
    dirs = np.tile(-front, (origins.shape[0], 1))
    tri, ray, _ = mesh.ray.intersects_id(origins, dirs, multiple_hits=False, return_locations=True)
    shade = np.zeros(RES * RES)
    n = mesh.face_normals[tri]
    shade[ray] = np.clip(n @ front, 0, 1) * 0.85 + 0.15
    img = Image.fromarray((shade.reshape(RES, RES) * 255).astype(np.uint8)).convert("RGB")
    d = ImageDraw.Draw(img)
    for k in range(0, RES, 50):
        colour = (255, 80, 80) if k % 100 == 0 else (120, 40, 40)
        d.line([(k, 0), (k, RES)], fill=colour, width=1)
        d.line([(0, k), (RES, k)], fill=colour, width=1)
        if k % 100 == 0:
            d.text((k + 2, 2), str(k), fill=(255, 255, 0))
            d.text((2, k + 2), str(k), fill=(255, 255, 0))
    img.save(a.out)
    view = {"mesh": a.mesh, "centre": centre.tolist(), "right": right.tolist(), "up": up.tolist(),
            "front": front.tolist(), "pixel": px, "res": RES}
    with open(a.out.rsplit(".", 1)[0] + ".json", "w") as f:
        json.dump(view, f, indent=1)
    print("wrote", a.out)


def pick(a):
    import trimesh

    view = json.load(open(a.view))
    mesh = load(view["mesh"])
    c, r, u, f = (np.array(view[k]) for k in ("centre", "right", "up", "front"))
    px, res = view["pixel"], view["res"]
    plane = None
    if a.plane:
        path, name = a.plane.rsplit(":", 1)
        plane = np.array(json.load(open(path))[name])
    out = {}
    for item in a.points:
        name, xy = item.split("=")
        x, y = (float(v) for v in xy.split(","))
        o = c + (x - res / 2 + 0.5) * px * r - (y - res / 2 + 0.5) * px * u + f * 10 * px * res
        if plane is not None:
            # The line of sight o − t f meets the plane through `plane` facing f.
            t = (o - plane) @ f
            q, _, _ = trimesh.proximity.closest_point(mesh, [o - t * f])
            out[name] = [round(float(v), 6) for v in q[0]]
            continue
        locs, _, _ = mesh.ray.intersects_location([o], [-f], multiple_hits=False)
        if len(locs) == 0:
            print(f"{name}: no surface at pixel {x},{y}", file=sys.stderr)
            continue
        out[name] = [round(float(v), 6) for v in locs[0]]
    print(json.dumps(out, indent=1))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("render")
    r.add_argument("mesh")
    r.add_argument("--up", required=True)
    r.add_argument("--front", required=True)
    r.add_argument("--centre", required=True)
    r.add_argument("--width", type=float, required=True)
    r.add_argument("--yaw", type=float, default=0.0)
    r.add_argument("--pitch", type=float, default=0.0)
    r.add_argument("--profile", action="store_true", help="view the face from the subject's right")
    r.add_argument("--out", required=True)
    p = sub.add_parser("pick")
    p.add_argument("view")
    p.add_argument("points", nargs="+")
    p.add_argument("--plane", default=None, help="PICKS.json:NAME — pick on the midsagittal plane through that point")
    a = ap.parse_args()
    render(a) if a.cmd == "render" else pick(a)


if __name__ == "__main__":
    main()
