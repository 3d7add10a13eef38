#!/usr/bin/env bash
# Exemplar synthesis against the peer (BENCHMARKS.md): derma synth and Embark's texture-synthesis
# CLI (installed here from crates.io, never vendored) on the same skin exemplars, same machine,
# same run, at 512², 1024² and 2048² from 128² and 256² exemplars. Times are whole-process wall
# clock (load, synthesise, write); the quality metrics of both outputs come from one program
# (derma-synth's 02_quality example: patch SWD at full, half and quarter resolution, contrast and
# grain ratios, verbatim-copy ratio, seam energy).
#   bash bench/synth.sh [SIZES...]      (default: 512 1024 2048)
# RUNS=n times each tool n times, alternating, and reports the median of each (default 1);
# EXEMPLARS="albedo128 ..." picks exemplars (default: all four; lps128 and lps256, held-out
# crops of a photographed albedo, once `python3 scripts/corpus.py fetch` has made target/corpus).
# Needs ../shared/data (the skin crops) and python3 with Pillow (for cropping and the figure).
set -euo pipefail
cd "$(dirname "$0")/.."
sizes=("${@:-512 1024 2048}")
read -r -a sizes <<<"${sizes[*]}"
data=../shared/data
out=bench/out/synth
mkdir -p "$out"
peer_root=target/peer
if [ ! -x "$peer_root/bin/texture-synthesis" ]; then
  cargo install --locked texture-synthesis-cli --version 0.8.3 --root "$peer_root"
fi
peer="$peer_root/bin/texture-synthesis"
python3 -c "import PIL" 2>/dev/null || python3 -m pip install -q pillow
cargo build --release -q -p derma -p derma-synth --example 02_quality
derma=target/release/derma
quality=target/release/examples/02_quality

# The exemplars, two grey and two colour (bench/synth_crops.py).
python3 bench/synth_crops.py "$data" "$out" target/corpus

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
csv="$out/results.csv"
echo "exemplar,size,tool,seconds,patch_swd,swd_half,swd_quarter,contrast,grain,verbatim_copy_ratio,seam_energy" >"$csv"
wall() { # seconds of wall clock of a command
  local t0 t1
  t0=$(date +%s.%N)
  "$@" >/dev/null 2>&1
  t1=$(date +%s.%N)
  python3 -c "print(f'{$t1 - $t0:.2f}')"
}
median() { python3 -c "import statistics, sys; print(f'{statistics.median(map(float, sys.argv[1:])):.2f}')" "$@"; }
runs=${RUNS:-1}
read -r -a exemplars <<<"${EXEMPLARS:-disp128 disp256 albedo128 albedo256x128}"
for ex in "${exemplars[@]}"; do
  for s in "${sizes[@]}"; do
    d_all=() p_all=()
    for _ in $(seq "$runs"); do
      d_all+=("$(wall "$derma" synth -q --exemplar "$out/$ex.png" --size "$s" --seed 1 --out "$out/${ex}_${s}_derma.png")")
      p_all+=("$(wall "$peer" --no-progress --seed 1 --out-size "$s" --out "$out/${ex}_${s}_peer.png" generate "$out/$ex.png")")
    done
    d_s=$(median "${d_all[@]}")
    p_s=$(median "${p_all[@]}")
    if [ "$runs" -gt 1 ]; then echo "$ex ${s}²: derma runs ${d_all[*]} s, peer runs ${p_all[*]} s"; fi
    for tool in derma peer; do
      secs=$d_s; [ $tool = peer ] && secs=$p_s
      read -r _ swd _ swd2 _ swd4 _ contrast _ grain _ verb _ seam \
        < <("$quality" "$out/$ex.png" "$out/${ex}_${s}_${tool}.png" 16)
      echo "$ex,$s,$tool,$secs,$swd,$swd2,$swd4,$contrast,$grain,$verb,$seam" >>"$csv"
    done
    python3 -c "print(f'$ex {$s}²: derma {$d_s} s, peer {$p_s} s, ratio {$p_s/$d_s:.1f}×')" 2>/dev/null \
      || echo "$ex ${s}²: derma $d_s s, peer $p_s s"
  done
done
column -s, -t "$csv"
