#!/usr/bin/env bash
# Main-job benchmark: `derma skin` on the built-in head at 2048² and 4096² (default features),
# best of N runs, with the per-stage breakdown from report.json.
# Usage: bench/skin.sh [runs]   (run from the repository root)
set -euo pipefail
runs=${1:-3}
cargo build --release -q -p derma
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(date -u +%Y-%m-%d)"
for size in 2048 4096; do
  for r in $(seq "$runs"); do
    ./target/release/derma skin --size "$size" --out "$out/$size-$r" --quiet
  done
  python3 - "$out" "$size" "$runs" <<'PY'
import json, sys
out, size, runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
reports = [json.load(open(f"{out}/{size}-{r}/report.json")) for r in range(1, runs + 1)]
best = min(reports, key=lambda r: [t["seconds"] for t in r["timings_s"] if t["stage"] == "total"][0])
stages = [(t["stage"], t["seconds"]) for t in best["timings_s"]]
mp = int(size) ** 2 / 1e6
total = dict(stages)["total"]
print(f"\n{size}x{size} ({mp:.1f} MP), {sum(best['counts'].values())} features, threads {best['threads']}, best of {runs}:")
for name, s in stages:
    print(f"  {name:14s} {s:7.2f} s")
print(f"  => {total / mp:.2f} s per megapixel (thesis: ~20 s/MP single-threaded, i.e. {20 * mp:.0f} s)")
PY
done
