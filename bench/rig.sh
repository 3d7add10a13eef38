#!/usr/bin/env bash
# Dynamic facial colour figures (BENCHMARKS.md): basis build for 4096² maps with 8 targets at
# r = 16…1024 texels, one 2048² colour frame with 8 targets (real-time and exact paths), and the
# full-resolution local statistics (block method vs the exact O(r) disk) at 1024².
set -euo pipefail
cd "$(dirname "$0")/.."
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
cargo bench -p derma-rig --bench rig 2>&1 | grep -E "^(rig_|local_)|time:"
