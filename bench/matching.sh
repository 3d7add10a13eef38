#!/usr/bin/env bash
# Model-matching figures: time to fit the committed grid (360 entries, all models), the residual
# summary, the Monte Carlo noise floor of the sampled BRDF, and the lookup speed for a 4096²
# texture set (criterion). The precompute table is rebuilt if missing (~20 min on 2 cores).
# Usage: bench/matching.sh [work-dir]
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-target/bench-matching}"
cargo build --release -q -p derma
bin=target/release/derma
grid=crates/derma-shading/data/match-grid.toml
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
mkdir -p "$work"
if [[ ! -f "$work/pre.dtab" ]]; then
  /usr/bin/time -f "precompute: %e s wall" "$bin" -q optics precompute --grid "$grid" --out "$work/pre" --device auto
  "$bin" -q optics merge "$work/pre" --out "$work/pre.dtab"
fi
for w in cosine uniform; do
  /usr/bin/time -f "fit ($w): %e s wall, %M KB peak" "$bin" -q match fit --grid "$work/pre.dtab" \
    --out "$work/table-$w.dtab" --weighting "$w"
done
# Noise floor: the same three nodes simulated with two seeds; relative weighted RMS of their
# difference / √2, over the bins the fit uses (cosine weights, zenith ≤ 80°).
for node in "0.005 32" "0.08 176" "0.5 320"; do
  set -- $node
  for s in 1 2; do
    "$bin" -q optics simulate --melanin "$1" --pheomelanin 0.45 --blood 0.015 --oxygenation 0.75 \
      --sc-um 15 --epidermis-um 40 --photons 400000 --seed "$s" --device cpu --json > "$work/noise-$2-$s.json"
  done
  python3 - "$work/noise-$2-1.json" "$work/noise-$2-2.json" "$1" <<'PY'
import json, math, sys
a, b = (json.load(open(p))["brdf_rgb"] for p in sys.argv[1:3])
num = den = 0.0
for ti in range(8):
    for to in range(8):
        w = math.cos((ti + .5) * math.pi / 18) * math.cos((to + .5) * math.pi / 18)
        for p in range(12):
            k = (ti * 9 + to) * 12 + p
            for c in range(3):
                num += w * (a[k][c] - b[k][c]) ** 2
                den += w * ((a[k][c] + b[k][c]) / 2) ** 2
print(f"noise floor, melanin {sys.argv[3]}: relative RMS {math.sqrt(num / den / 2):.3f} at 4e5 photons")
PY
done
cargo bench -q -p derma-shading --bench table_lookup 2>&1 | grep -E "^lookup|time:"
