#!/usr/bin/env bash
# Shen et al. §3.3's self-adaptive optimisation, measured (docs/synth.md, "Self-adaptive
# optimisation"): `derma synth --size 1024 --correction 0` from the bench crops (bench/synth_crops.py)
# after 0, 1, 2 and 3 optimisation passes, with the skip (--settle 2) and without (--settle 0,
# the default), under the search SEARCH (exhaustive, where the skip pays, by default; coherent,
# the default search, where it does not): seconds of each pass, windows searched, and the quality metrics (grain ratio,
# patch SWD, seam energy). Then S4 Fig. 3 remade: the 1024² output's top-left 256² after the
# patch pass and after each optimisation pass (docs/images/synth-passes.png). Needs python3
# with Pillow.
#   [SEARCH=coherent] bash bench/synth_adaptive.sh [SIZE]
set -euo pipefail
cd "$(dirname "$0")/.."
size=${1:-1024}
search=${SEARCH:-exhaustive}
cargo build --release -q -p derma
out=bench/out/adaptive
mkdir -p "$out"
python3 bench/synth_crops.py ../shared/data "$out"
d=target/release/derma
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F); --search $search"
echo "| exemplar | passes | settle | seconds | each pass (s) | windows searched (per pass) | grain ratio | patch SWD | seam energy |"
echo "|---|---|---|---|---|---|---|---|---|"
for ex in albedo256x128 albedo128 disp256; do
  for settle in 0 2; do
    for passes in 0 1 2 3; do
      m=$("$d" synth --exemplar "$out/$ex.png" --size "$size" --passes "$passes" --correction 0 \
        --settle "$settle" --search "$search" --metrics --out "$out/$ex-p$passes-s$settle.png" -q)
      python3 - "$ex" "$passes" "$settle" "$m" <<'PY'
import json, sys
ex, passes, settle, m = sys.argv[1], sys.argv[2], sys.argv[3], json.loads(sys.argv[4])
searched = " / ".join(f"{p['searched']}/{p['windows']}" for p in m["windows_searched"]) or "–"
sides = [p["side"] for p in m["windows_searched"]]
each = " / ".join("%.2f" % m["stages"]["optimisation %d×%d" % (w, w)] for w in sides) or "–"
print(f"| {ex} | {passes} | {settle} | {m['seconds']:.2f} | {each} | {searched} | {m['grain_ratio']:.3f} "
      f"| {m['patch_swd']:.5f} | {m['seam_energy']:.3f} |")
PY
    done
  done
done
python3 - "$out" <<'PY'
import sys
from PIL import Image, ImageDraw
d = sys.argv[1]
labels = ["patch pass", "1 optimisation", "2 optimisations", "3 optimisations"]
ims = [Image.open(f"{d}/albedo256x128-p{k}-s2.png").convert("RGB").crop((0, 0, 256, 256)) for k in range(4)]
out = Image.new("RGB", (4 * 256 + 3 * 6, 256 + 18), (255, 255, 255))
draw = ImageDraw.Draw(out)
for k, (im, label) in enumerate(zip(ims, labels)):
    out.paste(im, (k * 262, 18))
    draw.text((k * 262 + 4, 3), label, fill=(0, 0, 0))
out.save("docs/images/synth-passes.png", optimize=True)
print("docs/images/synth-passes.png", out.size)
PY
