#!/usr/bin/env bash
# GPU exemplar synthesis figures (BENCHMARKS.md): derma synth --device gpu at 512²…4096² from
# the 128² and 256² skin crops, with the CPU path on the same machine for the ratio, and a
# bitwise check that both give the same file. Run where the GPU is:
#   DERMA=path/to/derma EXEMPLARS=dir/with/disp128.png,disp256.png bash bench/synth_gpu.sh
# (bench/synth.sh writes the crops to bench/out/synth/.) DERMA must be a build with the gpu
# feature: cargo build --release -p derma --features gpu.
set -euo pipefail
derma=${DERMA:-target/release/derma}
ex=${EXEMPLARS:-bench/out/synth}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name --format=csv,noheader
for e in disp128 disp256; do
  for s in 512 1024 2048 4096; do
    g=$("$derma" synth -q --exemplar "$ex/$e.png" --size "$s" --device gpu --out "$tmp/g.png" --metrics)
    echo "$e ${s}² gpu: $g"
    if [ "$s" -le 2048 ]; then
      c=$("$derma" synth -q --exemplar "$ex/$e.png" --size "$s" --device cpu --out "$tmp/c.png" --metrics)
      echo "$e ${s}² cpu: $c"
      cmp -s "$tmp/g.png" "$tmp/c.png" && echo "$e ${s}²: GPU and CPU files identical" || echo "$e ${s}²: FILES DIFFER"
    fi
  done
done
