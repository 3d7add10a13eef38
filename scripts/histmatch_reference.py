#!/usr/bin/env python3
"""Reference values for derma-rig's histogram matching, from scikit-image.

Jimenez et al. 2010 (§4.1) approximate histogram matching by matching Gaussians (eq. 3). When
the disk radius covers the whole map, the rig's local matching becomes global matching, and
for near-Gaussian maps it must agree with exact CDF matching. This script draws a source and a
target map (fixed seeds, Gaussian values like a hemoglobin map's), matches the source to the
target with skimage.exposure.match_histograms, and writes all three to
crates/derma-rig/tests/data/histmatch_reference.json, which the Rust test reads.

    python3 scripts/histmatch_reference.py          # (re)write the reference
    python3 scripts/histmatch_reference.py --check  # recompute and compare with the committed file

Installs scikit-image from PyPI when it is missing (a peer for tests, not a dependency).
"""
import json
import subprocess
import sys
from pathlib import Path

try:
    import numpy as np
    from skimage.exposure import match_histograms
except ImportError:
    subprocess.check_call([sys.executable, "-m", "pip", "install", "--quiet", "scikit-image"])
    import numpy as np
    from skimage.exposure import match_histograms

OUT = Path(__file__).resolve().parent.parent / "crates/derma-rig/tests/data/histmatch_reference.json"
W, H = 48, 48


def compute():
    rng = np.random.RandomState(20101201)
    # Dermal blood volume fractions: neutral around 1.2 %, the target redder and more contrasted.
    source = np.clip(rng.normal(0.012, 0.002, (H, W)), 0.0, 1.0).astype(np.float32)
    target = np.clip(rng.normal(0.020, 0.0045, (H, W)), 0.0, 1.0).astype(np.float32)
    matched = match_histograms(source.astype(np.float64), target.astype(np.float64))
    return {
        "source": "skimage.exposure.match_histograms (scikit-image) on numpy RandomState(20101201) normal draws",
        "width": W,
        "height": H,
        "neutral": [float(str(v)) for v in source.ravel()],
        "target": [float(str(v)) for v in target.ravel()],
        "matched": [round(float(v), 9) for v in np.asarray(matched).ravel()],
    }


def main():
    ref = compute()
    if "--check" in sys.argv:
        old = json.loads(OUT.read_text())
        for key in ("neutral", "target", "matched"):
            a, b = np.array(old[key]), np.array(ref[key])
            err = float(np.max(np.abs(a - b)))
            if a.shape != b.shape or err > 1e-7:
                sys.exit(f"histmatch reference '{key}' differs from scikit-image by {err}")
        print("histmatch reference matches scikit-image")
        return
    OUT.write_text(json.dumps(ref) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
