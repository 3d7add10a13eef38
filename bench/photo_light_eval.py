"""Scores a bake against the scan's photographed albedo (bench/photo_light.sh): PSNR after a
per-channel gain fit (least squares in linear light), over the face texels the bake coloured
from photos (its mask.png) whose triangle lies in the face box the render wrote (face.json).
The gain fit takes out what no photo set can recover (the light's overall colour and level).

    python photo_light_eval.py MESH.obj ALBEDO.jpg SET_DIR BAKE_DIR [--diff OUT.png]
prints one line: PSNR (dB), face texels, the fitted gains.
    python photo_light_eval.py --loop MESH.obj SET_DIR BAKE_DIR CHROMO_DIR SKIN_SET_DIR
prints the chromophore loop's ΔE*ab: a skin set painted from the bake's maps against the bake.
"""

import json
import os
import sys

import numpy as np
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from objfile import read_obj  # noqa: E402


def srgb_to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c):
    c = np.clip(c, 0, 1)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def face_mask(V, VT, F, box, size):
    """Texels of the triangles whose corners all lie in the face box (UV v up, row 0 at top)."""
    x0, x1, y0, y1, z0 = box
    inside = (V[:, 0] > x0) & (V[:, 0] < x1) & (V[:, 1] > y0) & (V[:, 1] < y1) & (V[:, 2] > z0)
    mask = np.zeros((size, size), bool)
    for f in F:
        if not all(inside[c[0]] for c in f):
            continue
        for i in range(1, len(f) - 1):
            t = np.array([VT[f[0][1]], VT[f[i][1]], VT[f[i + 1][1]]]) * [size, size]
            t[:, 1] = size - t[:, 1]
            lo = np.floor(t.min(0)).astype(int)
            hi = np.ceil(t.max(0)).astype(int)
            ys, xs = np.mgrid[max(lo[1], 0):min(hi[1], size), max(lo[0], 0):min(hi[0], size)]
            px, py = xs + 0.5, ys + 0.5
            (ax, ay), (bx, by), (cx, cy) = t
            d = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)
            if abs(d) < 1e-12:
                continue
            l1 = ((by - cy) * (px - cx) + (cx - bx) * (py - cy)) / d
            l2 = ((cy - ay) * (px - cx) + (ax - cx) * (py - cy)) / d
            hit = (l1 >= 0) & (l2 >= 0) & (1 - l1 - l2 >= 0)
            mask[ys[hit], xs[hit]] = True
    return mask


def lab(rgb):
    """CIELAB (D65) of linear sRGB."""
    m = np.array([[0.4124564, 0.3575761, 0.1804375], [0.2126729, 0.7151522, 0.0721750],
                  [0.0193339, 0.1191920, 0.9503041]])
    t = rgb @ m.T / np.array([0.95047, 1.0, 1.08883])
    f = np.where(t > 0.008856, np.cbrt(t), 7.787 * t + 16 / 116)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])], -1)


def loop(mesh, set_dir, bake_dir, chromo_dir, painted_dir):
    """The chromophore loop: the skin set painted from the bake's maps against the bake's
    albedo over the exposure the inversion fitted, ΔE*ab over the face texels from photos."""
    bake = srgb_to_linear(np.asarray(Image.open(os.path.join(bake_dir, "albedo.png")).convert("RGB"), np.float64) / 255)
    painted = srgb_to_linear(np.asarray(Image.open(os.path.join(painted_dir, "base_color.png")).convert("RGB"), np.float64) / 255)
    exposure = json.load(open(os.path.join(chromo_dir, "chromophores.json")))["exposure"]
    size = bake.shape[0]
    coloured = np.asarray(Image.open(os.path.join(bake_dir, "mask.png")).convert("L")) > 127
    V, VT, F = read_obj(mesh)
    box = json.load(open(os.path.join(set_dir, "face.json")))["face_box"]
    m = face_mask(V, VT, F, box, size) & coloured
    de = np.linalg.norm(lab(painted[m]) - lab(bake[m] / exposure), axis=-1)
    print(f"loop ΔE*ab median {np.median(de):.2f}, 90th percentile {np.percentile(de, 90):.2f} over {m.sum()} face texels")


def main():
    if sys.argv[1] == "--loop":
        loop(*sys.argv[2:7])
        return
    mesh, albedo, set_dir, bake_dir = sys.argv[1:5]
    diff = sys.argv[sys.argv.index("--diff") + 1] if "--diff" in sys.argv else None
    name = "albedo.png" if os.path.exists(os.path.join(bake_dir, "albedo.png")) else "texture.png"
    bake = np.asarray(Image.open(os.path.join(bake_dir, name)).convert("RGB"), np.float64) / 255
    size = bake.shape[0]
    ref = Image.open(albedo).convert("RGB").resize((size, size), Image.BOX)
    ref = np.asarray(ref, np.float64) / 255
    coloured = np.asarray(Image.open(os.path.join(bake_dir, "mask.png")).convert("L")) > 127
    V, VT, F = read_obj(mesh)
    box = json.load(open(os.path.join(set_dir, "face.json")))["face_box"]
    m = face_mask(V, VT, F, box, size) & coloured
    b, r = srgb_to_linear(bake[m]), srgb_to_linear(ref[m])
    gains = (b * r).sum(0) / np.maximum((b * b).sum(0), 1e-12)
    fitted = linear_to_srgb(b * gains)
    mse = ((fitted - ref[m]) ** 2).mean()
    psnr = 10 * np.log10(1 / mse)
    print(f"{psnr:.1f} dB over {m.sum()} face texels; gains {' / '.join(f'{g:.2f}' for g in gains)}")
    if diff:
        out = np.zeros_like(bake)
        out[m] = np.clip(0.5 + 4 * (fitted - ref[m]), 0, 1)
        Image.fromarray((out * 255).astype(np.uint8)).save(diff)


main()
