#!/usr/bin/env bash
# Table 4.1's GPU rows on a GPU machine (BENCHMARKS.md, "Eye region"): jump flooding and the
# refined backtracking sampler at 1920×1080 on the device (mean of 50 back-to-back dispatches
# after a warm-up, no transfers), beside the CPU rows of the same run. Goal: JFA ≤ 0.25 ms on an
# H100/H200 (a plain CUDA JFA measured there: 0.23 ms).
#   bash bench/eyes_gpu.sh [path/to/derma]
set -euo pipefail
cd "$(dirname "$0")/.."
D=${1:-target/release/derma}
[ -x "$D" ] || { cargo build --release -q -p derma --features gpu; D=target/release/derma; }
echo "machine: $(nproc) cores, $(date -u +%F); $(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null || echo 'no nvidia-smi')"
"$D" eyes sdf --device gpu --runs 50 -o "${TMPDIR:-/tmp}/derma-eyes-gpu"
