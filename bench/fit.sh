#!/usr/bin/env bash
# `derma head fit` against density (BENCHMARKS.md, "Fitting your head"): the ground-truth scan of
# crates/derma-head/tests/support/truth.rs (the built-in head's outer skin retriangulated, slid,
# warped by 10 mm, turned and written in cm; seed 2), its triangles split into four 0–2 times
# (50 k, 200 k, 800 k vertices); whole-process wall time and peak memory of the fit, three runs
# each, and the accuracy the example measures in memory; then `derma eyes animate --head --mesh`
# on each (the eye model moving the scan's own vertices).
#   bash bench/fit.sh
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/common.sh
cargo build --release -q -p derma-head --example fit_truth
tmp=$W
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
for splits in 0 1 2; do
  SPLITS=$splits WRITE="$tmp/scan$splits.obj" target/release/examples/fit_truth 2 10 | grep '^seed' | cut -d';' -f1-4
  for run in 1 2 3; do
    rm -rf "$tmp/out"
    /usr/bin/time -f "  derma head fit, run $run: %e s wall, %M KB peak" \
      $D head fit --mesh "$tmp/scan$splits.obj" --out "$tmp/out" -q >/dev/null
  done
  # The eye model moving the scan's own vertices (4 s at 30 fps, no renders).
  rm -rf "$tmp/eyes"
  /usr/bin/time -f "  derma eyes animate --mesh: %e s wall, %M KB peak" \
    $D eyes animate --head "$tmp/out" --mesh "$tmp/scan$splits.obj" --render 0 --out "$tmp/eyes" -q >/dev/null
done
