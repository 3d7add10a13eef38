#!/usr/bin/env bash
# Issue 64's figures in one run, each beside its goal (BENCHMARKS.md, "Speed, round three"):
#  1. the main job, `derma skin --size N --out D -q`: wall time and peak memory of the whole
#     process (/usr/bin/time), three runs at 4096² (goal 4 s, 1.2 GB), one at 8192² (16 s, 4 GB),
#     and 1024², 2048² for the growth;
#  2. a new user's first command from a fresh clone with an empty cargo registry (its own
#     CARGO_HOME and target directory: `cargo fetch`, `cargo build --release -p derma`, then
#     `derma skin --out out/`; goal 4 min in all);
#  3. exemplar synthesis against texture-synthesis (bench/synth.sh at 1024² on the colour 128²
#     and 256×128 crops, and the held-out 128² and 256² crops of a photographed albedo where
#     scripts/corpus.py has fetched it, the median of three alternating runs; goal 10× the peer, grain ≥ 0.85,
#     patch SWD ≤ the peer's), the k-coherence search against the exhaustive one as the
#     exemplar's side doubles (128² → 256²: 4× the area), and the self-adaptive optimisation
#     with and without (bench/synth_adaptive.sh);
#  4. the optics' photons per second per core beside MCML (bench/mcml.sh).
# GPU figures come from bench/gpu.sh on a lent device.
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
  for size in 1024 2048 4096 4096 4096 8192; do
    rm -rf "$out/skin$size"
    /usr/bin/time -f "%e %M" -o "$out/time.txt" target/release/derma skin --size "$size" --out "$out/skin$size" -q >/dev/null
    read -r wall kb <"$out/time.txt"
    case $size in 4096) goal="goal 4 s, 1.2 GB" ;; 8192) goal="goal 16 s, 4 GB" ;; *) goal="growth" ;; esac
    echo "main job ${size}²: ${wall} s wall, $((kb / 1024)) MB peak ($goal)"
  done
  rm -rf "$out"/skin*
fi

if has build; then
  scratch=$(mktemp -d)
  trap 'rm -rf "$scratch"' EXIT
  git clone -q . "$scratch/derma"
  (
    cd "$scratch/derma"
    export CARGO_HOME="$scratch/cargo-home" CARGO_TARGET_DIR="$scratch/derma/target"
    s=$(date +%s.%N)
    cargo fetch -q
    f=$(date +%s.%N)
    cargo build --release -q -p derma
    m=$(date +%s.%N)
    target/release/derma skin --out out/ -q >/dev/null
    e=$(date +%s.%N)
    echo "first command (fresh clone, empty registry and target/): fetch $(echo "$f - $s" | bc) s, build $(echo "$m - $f" | bc) s, the main job $(echo "$e - $m" | bc) s; in all $(echo "$e - $s" | bc) s (goal 240 s)"
  )
  rm -rf "$scratch"
fi

if has synth; then
  # The held-out photographed crops too, where scripts/corpus.py has fetched their source.
  ex="albedo128 albedo256x128"
  [ -f target/corpus/Map-COL.jpg ] && ex="$ex lps128 lps256"
  RUNS=3 EXEMPLARS="$ex" bash bench/synth.sh 1024
  # Growth with the exemplar's area, each search scope (crops made by bench/synth.sh).
  pairs="albedo128:albedo256x128"
  [ -f target/corpus/Map-COL.jpg ] && pairs="$pairs lps128:lps256"
  for pair in $pairs; do
    for scope in coherent exhaustive; do
      line="search $scope:"
      for e in ${pair%%:*} ${pair##*:}; do
        /usr/bin/time -f "%e" -o "$out/time.txt" target/release/derma synth --exemplar \
          "bench/out/synth/$e.png" --size 1024 --search "$scope" --out "$out/scope.png" -q
        line="$line $e $(cat "$out/time.txt") s,"
      done
      echo "${line%,} (1024², one run each)"
    done
  done
  bash bench/synth_adaptive.sh 1024
fi

if has optics; then
  bash bench/mcml.sh
fi
