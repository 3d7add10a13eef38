#!/usr/bin/env bash
# How exemplar synthesis grows with the output's size (BENCHMARKS.md, "Synthesis grows
# linearly"): derma synth on the CPU from the grey and colour 128² bench crops at 512², 1024²,
# 1448² and 2048² (1×, 4×, 8×, 16× the texels), whole-process wall and CPU time and peak memory
# (/usr/bin/time), and the patch pass's seconds and the quality metrics (--metrics).
#   bash bench/synth_growth.sh [SIZES...]      (default: 512 1024 1448 2048)
# Needs ../shared/data (the skin crops) and python3 with Pillow.
set -euo pipefail
cd "$(dirname "$0")/.."
sizes=("${@:-512 1024 1448 2048}")
read -r -a sizes <<<"${sizes[*]}"
out=bench/out/synth
mkdir -p "$out"
python3 -c "import PIL" 2>/dev/null || python3 -m pip install -q pillow
python3 bench/synth_crops.py ../shared/data "$out"
source bench/common.sh
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
printf '%-10s %6s %8s %8s %9s %8s %6s %7s %8s\n' exemplar size wall_s cpu_s peak_MB patch_s grain swd contrast
for ex in albedo128 disp128; do
  for s in "${sizes[@]}"; do
    /usr/bin/time -f "%e %U %S %M" -o "$W/time" "$D" synth -q --exemplar "$out/$ex.png" \
      --size "$s" --seed 1 --device cpu --metrics --out "$W/$ex-$s.png" >"$W/metrics.json"
    python3 - "$ex" "$s" "$W/metrics.json" "$W/time" <<'PY'
import json, sys
ex, s, metrics, timing = sys.argv[1:]
m = json.load(open(metrics))
wall, user, system, peak_kb = open(timing).read().split()[-4:]
print(f"{ex:<10} {s:>6} {float(wall):8.2f} {float(user) + float(system):8.2f} "
      f"{int(peak_kb) / 1024:9.0f} {m['stages']['patch pass']:8.2f} {m['grain_ratio']:6.3f} "
      f"{m['patch_swd']:7.4f} {m['contrast_ratio']:8.3f}")
PY
  done
done
