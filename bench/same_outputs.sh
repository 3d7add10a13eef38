#!/usr/bin/env bash
# Runs two derma binaries on the same inputs and seeds and compares everything they write
# (bench/compare_outputs.py): the full `derma skin --size 512` set (head, and an analytic patch),
# `derma synth` (grey and joint colour + height, tileable), a rig (build, frame, preview,
# animation), the optics (`slab --json`, `simulate --json --plot`), a skin-colour LUT and a
# model fit with its plots, the eyes (synthetic data, a trained model, an animation with frames,
# the distance fields and lake), photos (a synthetic set, calibration, unwrap, bake,
# chromophores, iris, teeth) and renders (`derma render` with the GPU renderer where one opens,
# a GLB and a web export). Used to show that a refactor changed no output.
#   bash bench/same_outputs.sh BEFORE_BINARY AFTER_BINARY [WORK_DIR]
# Exit status 0 when every file is identical or equal in content (see compare_outputs.py).
set -euo pipefail
before=$(realpath "$1"); after=$(realpath "$2")
work=${3:-$(mktemp -d)}
here=$(cd "$(dirname "$0")" && pwd)
python3 -m pip install --quiet numpy OpenEXR pillow >/dev/null 2>&1 || true
mkdir -p "$work/inputs"
in=$work/inputs
# Shared inputs, made once by the first binary: both binaries then read the same bytes.
"$before" skin --size 256 --seed 11 --out "$in/skin" --quiet
"$before" skin --patch 30 --size 256 --seed 5 --out "$in/patch" --quiet
cat > "$in/curves.csv" <<'CSV'
time,happiness,anger
0,0,0
0.1,0.6,0
0.2,0.2,0.5
CSV
# A two-node grid with coarse bins (the axes as one inline table).
printf '%s\n' 'photons = 3000' 'seed = 2' 'brdf = [3, 3, 4]' 'profile_bins = 8' \
  'axes = { melanin = [0.02, 0.2], pheomelanin = [0.3], blood = [0.02], oxygenation = [0.75], stratum_corneum_um = [15.0], epidermis_um = [60.0] }' \
  > "$in/grid.toml"
"$before" optics precompute --grid "$in/grid.toml" --out "$in/pre" --device cpu --quiet
"$before" optics merge "$in/pre" --out "$in/pre.dtab" >/dev/null

run() { # run BINARY OUT_DIR
  local d=$1 o=$2
  mkdir -p "$o"
  "$d" skin --size 512 --seed 3 --out "$o/skin" --quiet
  "$d" skin --patch 30 --size 256 --seed 5 --appearance analytic --out "$o/patch" --quiet
  "$d" synth --exemplar "$in/patch/height.png" --size 160 --seed 2 --device cpu --out "$o/synth/grey.png" --quiet
  "$d" synth --exemplar "$in/patch/base_color.png" --exemplar-channels "height=$in/patch/height.png" \
       --size 128 --tile --seed 4 --device cpu --out "$o/synth/joint.exr" --quiet
  # From the set (a rig of bare maps would replace the set's colour: `export web` refuses it).
  "$d" rig build --set "$in/skin" --builtin all --radius 24 --out "$o/rig" --quiet
  mkdir -p "$o/frame" "$o/fit" "$o/lut"
  "$d" rig eval --rig "$o/rig" --weights happiness=0.7,anger=0.3 --device cpu --out "$o/frame/color.png" \
       --hemoglobin "$o/frame/hemoglobin.exr" --preview "$o/frame/preview.png" > "$o/frame/stdout.txt"
  "$d" rig animate --rig "$o/rig" --curves "$in/curves.csv" --fps 10 --out "$o/animation" --quiet
  "$d" optics slab --layer 1,1,100,0.9,1.4 --photons 200000 --device cpu --json > "$o/slab.json"
  "$d" optics simulate --melanin 0.05 --photons 50000 --device cpu --out "$o/simulate" --plot --quiet > /dev/null
  "$d" match lut --size 6 --photons 2000 --device cpu --out "$o/lut/lut.png" --out "$o/lut/lut.dtab" --quiet > /dev/null
  "$d" match fit --grid "$in/pre.dtab" --anneal-steps 300 --out "$o/fit/table.dtab" --plots "$o/fit/plots" --quiet | sed -E -e "s/ in [0-9.]+ s/ in (time) s/" -e "s|$o|OUT|g" > "$o/fit/stdout.txt"
  # The eye region: synthetic tracked data, a model trained on it, an animation with frames, and
  # the distance fields with the lake.
  mkdir -p "$o/eyes"
  "$d" eyes synthetic --seconds 3 --fps 10 --out "$o/eyes/tracked.csv" --quiet > /dev/null
  "$d" eyes train --data "$o/eyes/tracked.csv" --out "$o/eyes/model" --quiet > /dev/null
  "$d" eyes animate --model "$o/eyes/model/model.json" --seconds 1 --fps 10 --render 160 --out "$o/eyes/anim" --quiet > /dev/null
  "$d" eyes sdf --width 256 --height 144 --runs 1 --out "$o/eyes/sdf" --quiet > /dev/null
  # Photos: a synthetic set through calibration, unwrap, bake and chromophores; iris and teeth.
  mkdir -p "$o/photo"
  "$d" photo synthetic --width 800 --out "$o/photo/set" --quiet
  "$d" photo calibrate --points "$o/photo/set/points.json" --out "$o/photo/cameras.json" --quiet > "$o/photo/calibrate.txt"
  "$d" photo unwrap --mesh "$o/photo/set/face.obj" --out "$o/photo/face_uv.obj" --quiet > "$o/photo/unwrap.txt"
  "$d" photo bake --mesh "$o/photo/face_uv.obj" --cameras "$o/photo/cameras.json" --size 256 --out "$o/photo/bake" --quiet > "$o/photo/bake.txt"
  "$d" photo chromophores --texture "$o/photo/bake/albedo.exr" --mask "$o/photo/bake/mask.png" --out "$o/photo/chromo" --quiet > "$o/photo/chromo.txt"
  "$d" photo iris --photo "$o/eyes/sdf/lake.png" --size 128 --out "$o/photo/iris" --quiet > "$o/photo/iris.txt"
  "$d" photo teeth --photo "$o/eyes/sdf/lake.png" --size 128 --out "$o/photo/teeth" --quiet > "$o/photo/teeth.txt" || true
  # Renders of the skin set on the GPU renderer (any adapter, e.g. lavapipe; binaries from
  # before `derma render --device` always took one), GLB and web.
  local gpu=()
  # (A build without the gpu feature says "CPU only" in --version and renders on the CPU.)
  if "$d" render --help | grep -q -- --device && ! "$d" --version | grep -q 'CPU only'; then
    gpu=(--device gpu)
  fi
  "$d" render "$in/skin" --size 160x120 "${gpu[@]}" --out "$o/render" --quiet
  mkdir -p "$o/export"
  "$d" export glb "$in/skin" --out "$o/export/head.glb" --quiet
  "$d" export web "$in/skin" --rig "$o/rig" --out "$o/export/web" --quiet
}
rm -rf "$work/before" "$work/after"
run "$before" "$work/before"
run "$after" "$work/after"
python3 "$here/compare_outputs.py" "$work/before" "$work/after"
