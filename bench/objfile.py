"""The OBJ reader of the photo-light bench (bench/photo_light.py in Blender, bench/photo_light_eval.py):
positions, UVs and faces as (position, UV) index pairs, as the file has them (numpy only)."""

import numpy as np


def read_obj(path):
    """Positions (n × 3), UVs (m × 2) and faces, each a list of [position, uv] indices (uv -1
    where the corner has none)."""
    V, VT, F = [], [], []
    for line in open(path):
        if line.startswith("v "):
            V.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("vt "):
            VT.append([float(x) for x in line.split()[1:3]])
        elif line.startswith("f "):
            # "v", "v/vt", "v//vn" or "v/vt/vn": a corner without a UV gets -1.
            F.append([[int(i) - 1 if i else -1 for i in (c.split("/") + [""])[:2]] for c in line.split()[1:]])
    return np.array(V), np.array(VT), F
