#!/usr/bin/env bash
# Photos under light derma did not make (docs/photo.md, "Photos under independent light";
# BENCHMARKS.md): the Lee Perry-Smith head scan (CC BY 3.0, scripts/corpus.py) wearing its own
# photographed albedo, path-traced by Blender Cycles (Debian's blender) from five cameras under
# five kinds of light and unlit (bench/photo_light.py), then baked by derma three ways — the lighting kept
# with the true cameras, de-lit with the true cameras, de-lit with the cameras calibrated from
# the clicks (the default path) — and each bake scored against the albedo
# (bench/photo_light_eval.py: face PSNR after a per-channel gain fit).
#   bash bench/photo_light.sh                 (all kinds; KINDS="area point" for some,
#                                               WIDTH / SAMPLES for the renders, SIZE the bake)
#   bash bench/photo_light.sh --no-render     (re-bake and re-score the sets already rendered)
# Writes bench/out/photo_light/KIND/ (the photos, points.json, truth.json, the bakes) and
# bench/out/photo_light/table.md.
set -euo pipefail
cd "$(dirname "$0")/.."
render=1
[ "${1:-}" = "--no-render" ] && render=0
if ! command -v blender >/dev/null || ! /usr/bin/python3 -c 'import numpy' 2>/dev/null; then
  apt-get install -y blender python3-numpy || { apt-get update && apt-get install -y blender python3-numpy; }
fi
mesh=target/corpus/leeperrysmith.obj
albedo=target/corpus/Map-COL.jpg
[ -f "$mesh" ] && [ -f "$albedo" ] || python3 scripts/corpus.py fetch --only leeperrysmith
venv=target/peer-light
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q numpy pillow
fi
py="$venv/bin/python"
# DERMA: another derma binary to score (e.g. an older build, for a before/after table).
if [ -z "${DERMA:-}" ]; then
  cargo build --release -q -p derma
fi
D=${DERMA:-$PWD/target/release/derma}
out=bench/out/photo_light
mkdir -p "$out"
size=${SIZE:-1024}
table="$out/table.md"
{
  echo "machine: $(nproc) cores, $(date -u +%F); renders ${WIDTH:-1000} px wide, ${SAMPLES:-96} samples; bakes ${size}²"
  echo
  echo "| light (Cycles) | lighting kept, true cameras | de-lit, true cameras | de-lit, cameras from the clicks | chromophore loop ΔE*ab (median, 90th pct.) | what the default bake said |"
  echo "|---|---:|---:|---:|---|---|"
} >"$table"
for kind in ${KINDS:-flat lambert area point hdri sky}; do
  set_dir="$out/$kind"
  if [ "$render" = 1 ]; then
    rm -rf "$set_dir"
    env -u VIRTUAL_ENV -u PYTHONPATH blender -b --factory-startup --python-exit-code 1 \
      --python bench/photo_light.py -- "$mesh" "$albedo" "$kind" "$set_dir" \
      --width "${WIDTH:-1000}" --samples "${SAMPLES:-96}" 2>&1 | grep -E "derma photo_light|Error" || true
  fi
  $D photo calibrate --points "$set_dir/points.json" --mesh "$mesh" --out "$set_dir/cameras.json" -q
  row="| $kind"
  for bake in "kept truth.json --keep-lighting" "delit truth.json" "clicks cameras.json"; do
    set -- $bake
    rm -rf "${set_dir:?}/$1"
    $D photo bake --mesh "$mesh" --cameras "$set_dir/$2" --size "$size" ${3:-} --out "$set_dir/$1" \
      >"$set_dir/$1.log" 2>&1 || { cat "$set_dir/$1.log"; exit 1; }
    score=$("$py" bench/photo_light_eval.py "$mesh" "$albedo" "$set_dir" "$set_dir/$1" --diff "$set_dir/$1/diff.png")
    echo "$kind $1: $score"
    row="$row | ${score%% dB*} dB"
  done
  said=$(grep -h -E "^(warning|lighting model)" "$set_dir/clicks.log" | sed 's/ (held-out misfit of each.*//' | tr '\n' ' ' | sed 's/|/\//g')
  # The chromophore loop on the default bake: its maps painted back by derma skin on the scan.
  rm -rf "$set_dir/chromo" "$set_dir/painted"
  $D photo chromophores --texture "$set_dir/clicks/albedo.png" --mask "$set_dir/clicks/mask.png" \
    --out "$set_dir/chromo" -q
  # Features off: a mesh without fields gets them everywhere, and the loop is the colour's.
  { printf '[baseline]\nmelanin_map = "%s"\nblood_map = "%s"\n' "$PWD/$set_dir/chromo/melanin.exr" \
      "$PWD/$set_dir/chromo/hemoglobin.exr"
    for f in cyst eyebrow follicle freckle lips mole pore wrinkle; do printf '[%s]\nenabled = false\n' $f; done
  } >"$set_dir/loop.toml"
  $D skin --config "$set_dir/loop.toml" --mesh "$mesh" --size "$size" --out "$set_dir/painted" -q
  looped=$("$py" bench/photo_light_eval.py --loop "$mesh" "$set_dir" "$set_dir/clicks" "$set_dir/chromo" "$set_dir/painted")
  fit=$(python3 -c "import json;print(round(json.load(open('$set_dir/chromo/chromophores.json'))['median_delta_e'],2))")
  echo "$kind $looped; the inversion's own median $fit"
  echo "$row | ${looped#loop ΔE\*ab median } (inversion alone $fit) | $said |" >>"$table"
done
cat "$table"
