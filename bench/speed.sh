#!/usr/bin/env bash
# Issue 39's figures in one run, on this machine (BENCHMARKS.md, "Speed, round two"):
#  1. the main job, `derma skin --size N --out D -q`, at 4096² and 8192²: wall time and peak
#     memory of the whole process (/usr/bin/time), three runs at 4096², one at 8192²;
#  2. a new user's first command in a scratch clone with its own target directory:
#     `cargo build --release -p derma` then `derma skin --out out/` (crates already downloaded:
#     the figure is compile time, not the network's);
#  3. exemplar synthesis against texture-synthesis (bench/synth.sh at 1024²: two grey and two
#     colour exemplars, the median of three alternating runs of each tool, ratios and quality
#     in its table);
#  4. the optics' photons per second per core beside MCML (bench/mcml.sh).
#   bash bench/speed.sh [main] [build] [synth] [optics]    (default: all four)
set -euo pipefail
cd "$(dirname "$0")/.."
parts=("${@:-main build synth optics}")
read -r -a parts <<<"${parts[*]}"
has() { [[ " ${parts[*]} " == *" $1 "* ]]; }
out=bench/out/speed
mkdir -p "$out"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(free -g | awk '/Mem:/ {print $2}') GiB, $(date -u +%F)"

if has main; then
  cargo build --release -q -p derma
  for size in 4096 4096 4096 8192; do
    rm -rf "$out/skin$size"
    /usr/bin/time -f "%e %M" -o "$out/time.txt" target/release/derma skin --size "$size" --out "$out/skin$size" -q >/dev/null
    read -r wall kb <"$out/time.txt"
    echo "main job ${size}²: ${wall} s wall, $((kb / 1024)) MB peak"
  done
  rm -rf "$out"/skin*
fi

if has build; then
  scratch=$(mktemp -d)
  trap 'rm -rf "$scratch"' EXIT
  git clone -q . "$scratch/derma"
  (
    cd "$scratch/derma"
    s=$(date +%s.%N)
    cargo build --release -q -p derma
    m=$(date +%s.%N)
    target/release/derma skin --out out/ -q >/dev/null
    e=$(date +%s.%N)
    echo "first build (fresh clone, empty target/): $(echo "$m - $s" | bc) s; then the main job $(echo "$e - $m" | bc) s"
  )
  rm -rf "$scratch"
fi

if has synth; then
  RUNS=3 bash bench/synth.sh 1024
fi

if has optics; then
  bash bench/mcml.sh
fi
