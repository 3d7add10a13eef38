#!/usr/bin/env bash
# Renderer figures (BENCHMARKS.md): frame time of the built-in head with a 1024² texture set —
# shadow map, forward pass, separable subsurface blur, refracting eyes, composite — at 1024² and
# 1920×1080, frame after frame without read-back, on whatever adapter wgpu opens (Mesa's
# lavapipe on a machine without a GPU); then one `derma render --device gpu` (the GPU renderer on
# any adapter) of both setups with read-back and PNG encoding. FRAMES (default 20) per size.
set -euo pipefail
cd "$(dirname "$0")/.."
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release -q -p derma -p derma-skin --features derma/gpu,derma-skin/gpu --example 05_frame_time
target/release/examples/05_frame_time 1024,1920x1080 "${FRAMES:-20}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
target/release/derma skin --size 1024 --out "$work/skin" --quiet
/usr/bin/time -f "derma render (2 setups, 1024², with read-back and PNG): %e s wall, %M KB peak" \
  target/release/derma render "$work/skin" --device gpu --out "$work/render" --quiet
