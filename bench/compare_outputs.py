#!/usr/bin/env python3
"""Compares two output trees of derma file by file (bench/same_outputs.sh).

Each file is reported as one of:
  identical       the bytes are the same;
  same content    JSON equal once run-dependent keys (timings, seconds) are dropped, numbers
                  are compared at the f32 precision derma computes them in (a float printed
                  '0.04' instead of '0.03999999910593033' is the same value) and the renames
                  of TEXT_RENAMES are applied;
  same data       OpenEXR channels with equal pixels, where a channel was renamed as listed in
                  RENAMED (e.g. hemoglobin.exr's 'blood' → 'hemoglobin'); GLBs with the same
                  scene and buffers whose embedded images decode to equal pixels;
  DIFFERENT       anything else (exit status 1).
Paths under either tree's root compare equal (reports name the files they wrote), and the
files of TIMING_FILES hold a run's timings only.
Needs numpy, OpenEXR and Pillow (pip install numpy OpenEXR pillow).
"""
import json
import math
import sys
from pathlib import Path

# Keys whose values depend on the run (wall clock), not on the inputs.
VOLATILE = {"seconds", "photons_per_s", "timings_s", "stages", "ms", "seconds_per_frame", "total_seconds"}
# Files that hold only a run's timings beside numbers another file carries (eyes/sdf/table.md
# prints table.json's errors with their milliseconds).
TIMING_FILES = {"eyes/sdf/table.md"}
# The two trees' roots, replaced by OUT in strings (reports name the files they wrote).
ROOTS = []
# Channel renames between the two trees (old name → new name).
RENAMED = {"blood": "hemoglobin"}
# The same renames in identifiers and prose of JSON files (a key spelled `colour_space` before
# and `color_space` after, a manifest describing hemoglobin.exr's channel).
TEXT_RENAMES = [("colour", "color"), ("(blood)", "(hemoglobin)")]


def renamed(text):
    for old, new in TEXT_RENAMES:
        text = text.replace(old, new)
    return text


def f32(x):
    import numpy as np
    return float(np.float32(x))


def same_json(a, b, path="$"):
    if isinstance(a, dict) and isinstance(b, dict):
        ka = {k for k in a if k not in VOLATILE}
        kb = {k for k in b if k not in VOLATILE}
        # A key renamed by the change (colour_space → color_space) counts as the same key.
        norm = renamed
        if {norm(k) for k in ka} != {norm(k) for k in kb}:
            return f"{path}: keys {sorted(ka ^ kb)}"
        by_norm = {norm(k): k for k in kb}
        for k in ka:
            r = same_json(a[k], b[by_norm[norm(k)]], f"{path}.{k}")
            if r:
                return r
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{path}: lengths {len(a)} vs {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            r = same_json(x, y, f"{path}[{i}]")
            if r:
                return r
        return None
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if a == b or f32(a) == f32(b) or (math.isnan(a) and math.isnan(b)):
            return None
        return f"{path}: {a} vs {b}"
    if isinstance(a, str) and isinstance(b, str):
        for root in ROOTS:
            a, b = a.replace(root, "OUT"), b.replace(root, "OUT")
        if a == b or renamed(a) == renamed(b):
            return None
        return f"{path}: {a!r} vs {b!r}"
    return None if a == b else f"{path}: {a!r} vs {b!r}"


def exr_channels(p):
    import OpenEXR
    with OpenEXR.File(str(p), separate_channels=True) as f:
        return {n: c.pixels.copy() for n, c in f.parts[0].channels.items()}


def same_exr(a, b):
    import numpy as np
    ca, cb = exr_channels(a), exr_channels(b)
    ca = {RENAMED.get(n, n): v for n, v in ca.items()}
    if set(ca) != set(cb):
        return f"channels {sorted(ca)} vs {sorted(cb)}"
    for n in ca:
        if ca[n].dtype != cb[n].dtype or not np.array_equal(ca[n], cb[n]):
            return f"channel {n} differs"
    return None


def glb_parts(p):
    import struct
    b = p.read_bytes()
    n = struct.unpack_from("<I", b, 12)[0]
    doc = json.loads(b[20:20 + n])
    at = 20 + n
    bin_len = struct.unpack_from("<I", b, at)[0] if at < len(b) else 0
    return doc, b[at + 8:at + 8 + bin_len]


def same_glb(a, b):
    """Equal scenes: the same JSON but for buffer offsets and lengths, the same bytes in every
    buffer view, except embedded images, which must decode to the same pixels (an encoder's
    compression settings change only the bytes)."""
    import io
    import numpy as np
    from PIL import Image
    (da, ba), (db, bb) = glb_parts(a), glb_parts(b)
    image_views = {im["bufferView"] for im in da.get("images", []) if "bufferView" in im}

    def layout_free(d):
        d = json.loads(json.dumps(d))
        for v in d.get("bufferViews", []):
            v.pop("byteOffset", None)
            v.pop("byteLength", None)
        for buf in d.get("buffers", []):
            buf.pop("byteLength", None)
        return d
    why = same_json(layout_free(da), layout_free(db))
    if why:
        return why
    for i, (va, vb) in enumerate(zip(da["bufferViews"], db["bufferViews"])):
        xa = ba[va.get("byteOffset", 0):va.get("byteOffset", 0) + va["byteLength"]]
        xb = bb[vb.get("byteOffset", 0):vb.get("byteOffset", 0) + vb["byteLength"]]
        if i in image_views:
            pa = np.asarray(Image.open(io.BytesIO(xa)))
            pb = np.asarray(Image.open(io.BytesIO(xb)))
            if pa.shape != pb.shape or not np.array_equal(pa, pb):
                return f"image in buffer view {i}: pixels differ"
        elif xa != xb:
            return f"buffer view {i} differs"
    return None


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: compare_outputs.py BEFORE_DIR AFTER_DIR")
    before, after = Path(sys.argv[1]), Path(sys.argv[2])
    ROOTS.extend([str(before.resolve()), str(after.resolve()), str(before), str(after)])
    bad = 0
    files = sorted(p.relative_to(before) for p in before.rglob("*") if p.is_file())
    extra = sorted(
        p.relative_to(after) for p in after.rglob("*")
        if p.is_file() and not (before / p.relative_to(after)).exists()
    )
    for rel in files:
        a, b = before / rel, after / rel
        if not b.exists():
            print(f"DIFFERENT     {rel}: missing after")
            bad += 1
            continue
        if a.read_bytes() == b.read_bytes():
            print(f"identical     {rel}")
            continue
        why = "bytes differ"
        if str(rel) in TIMING_FILES:
            print(f"same content  {rel} (timings of the run only)")
            continue
        if rel.suffix == ".json":
            why = same_json(json.loads(a.read_text()), json.loads(b.read_text()))
            if why is None:
                print(f"same content  {rel} (JSON: equal but for formatting and run-dependent keys)")
                continue
        elif rel.suffix == ".glb":
            why = same_glb(a, b)
            if why is None:
                print(f"same data     {rel} (GLB: same scene and buffers; embedded images with equal pixels)")
                continue
        elif rel.suffix == ".exr":
            why = same_exr(a, b)
            if why is None:
                print(f"same data     {rel} (EXR: equal pixels; channels renamed {RENAMED})")
                continue
        print(f"DIFFERENT     {rel}: {why}")
        bad += 1
    for rel in extra:
        print(f"DIFFERENT     {rel}: only after")
        bad += 1
    print(f"{len(files)} files compared, {bad} different")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
