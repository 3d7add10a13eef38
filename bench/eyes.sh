#!/usr/bin/env bash
# The eye region against its goals and peers (BENCHMARKS.md, "Eye region"), same machine, same run:
#  1. Table 4.1 at 1920×1080 on the built-in head's eye close-up: every sampler and the exact
#     baselines (derma eyes sdf: median of 7 runs, all cores, then one core), and SciPy's exact
#     EDT (scipy.ndimage.distance_transform_edt, one core) on the same mask.
#  2. One model frame on one core (criterion: the linear model alone and the whole frame).
#  3. A 4 s animation at 30 fps (curves, GLB) end to end.
#   bash bench/eyes.sh
# Needs python3 with venv (scipy, numpy, pillow are installed into target/peer-eyes, never into
# the product).
set -euo pipefail
cd "$(dirname "$0")/.."
out=bench/out/eyes
mkdir -p "$out"
venv=target/peer-eyes
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q scipy numpy pillow
fi
py="$venv/bin/python"
cargo build --release -q -p derma
D=target/release/derma
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
echo "peer: SciPy $("$py" -c 'import scipy; print(scipy.__version__)')"

echo "== 1. Table 4.1, all cores"
$D eyes sdf --runs 7 -o "$out/sdf"
echo "== 1. Table 4.1, one core"
RAYON_NUM_THREADS=1 $D eyes sdf --runs 7 -o "$out/sdf1" | grep -E "exact|backtracking 6x8, 3"
"$py" - "$out/sdf/mask.png" <<'PY'
import sys, time
import numpy as np
from PIL import Image
from scipy import ndimage
m = np.array(Image.open(sys.argv[1]))
skin = np.abs(m.astype(int) - 128) < 20   # mask.png: 0 nothing, 128 skin, 255 eye
times = []
for _ in range(7):
    t = time.perf_counter()
    d = ndimage.distance_transform_edt(~skin)
    times.append(time.perf_counter() - t)
print(f"SciPy distance_transform_edt {m.shape[1]}x{m.shape[0]}: median {1e3 * sorted(times)[3]:.1f} ms (one core)")
PY

echo "== 2. One model frame (criterion)"
cargo bench -q -p derma-eyes --bench eyes -- "eye frame" 2>&1 | grep -E "^eye frame|time:"

echo "== 3. Animation end to end"
s=$(date +%s.%N)
$D eyes animate --seconds 4 --fps 30 --render 0 -o "$out/anim" | head -1
e=$(date +%s.%N)
echo "derma eyes animate --seconds 4 --fps 30 --render 0: $(echo "$e - $s" | bc) s"
