#!/usr/bin/env bash
# GPU figures in one run (issue 16; BENCHMARKS.md): derma's photon transport on the 1-layer slab
# at 10⁸ and 10⁹ photons (R and T against adding–doubling, the f32 kernel's error budget) and MCX
# (pmcx, from its wheel) on the same slab, the skin specimen's
# photons/s, exemplar synthesis at 1024²–4096² from the 256² crop (with the CPU's file compared
# at 1024²), and the rig's GPU frame at 2048² and 4096² with 8 targets. Sized for well under 10
# minutes on one data-centre GPU. Run where the GPU is:
#   DERMA=path/to/derma RIG_BENCH=path/to/rig-bench LAYOUT_BENCH=path/to/gpu_layout-bench \
#   EXEMPLARS=dir bash bench/gpu.sh
# DERMA: the release binary built with the `gpu` feature (`cargo build --release -p derma
# --features gpu`; default target/release/derma). RIG_BENCH: the criterion binary of
# `cargo bench -p derma-rig --features gpu --bench rig --no-run` (target/release/deps/rig-*; skipped if unset).
# LAYOUT_BENCH: that of `cargo bench -p derma-optics --features gpu --bench gpu_layout --no-run`
# (target/release/deps/gpu_layout-*): photons/s per kernel layout, to tune Kernel::for_device.
# EXEMPLARS: a folder with disp256.png (disp128.png for QUICK; bench/synth.sh writes both to
# bench/out/synth).
# PMCX_WHEELS: a folder holding the pmcx wheel (and numpy's, where the machine lacks numpy) to
# install from where there is no network.
# QUICK=1: tiny sizes, to check the script on any adapter (lavapipe included).
# A headless NVIDIA machine whose Vulkan ICD (libGLX_nvidia) cannot create an instance: carry
# this machine's libvulkan.so.1 and point the loader at the EGL library instead, e.g.
#   LD_LIBRARY_PATH=DIR:/usr/lib VK_ICD_FILENAMES=DIR/nvidia_egl_icd.json
# with the JSON's "library_path" set to libEGL_nvidia.so.0's path.
set -euo pipefail
derma=${DERMA:-target/release/derma}
ex=${EXEMPLARS:-bench/out/synth}
quick=${QUICK:-0}
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
if [ "$quick" = 1 ]; then
  photons=(100000); skin=41000; sizes=(128); exname=disp128
  frames_filter="gpu_frame_8_targets/2048"; mcx_n=100000
else
  photons=(100000000 1000000000); skin=41000000; sizes=(1024 2048 4096); exname=disp256
  frames_filter="gpu_frame"; mcx_n=100000000
fi
field() { python3 -c "import json, sys; print(json.load(sys.stdin)$1)"; }

# 1. Photon transport, 1-layer slab (1 mm, μa 1 /cm, μs 100 /cm, g 0.9, n 1.4 in air).
for n in "${photons[@]}"; do
  "$derma" -q optics slab --layer 1,1,100,0.9,1.4 --photons "$n" --device gpu --json >"$tmp/slab.json"
  echo "derma slab gpu, $n photons: $(field "['photons_per_s']" <"$tmp/slab.json") photons/s," \
    "absorbed $(field "['absorbed']" <"$tmp/slab.json"), $(field "['seconds']" <"$tmp/slab.json") s"
  # The f32 kernel against adding–doubling (iadpython, crates/derma-optics/tests/data).
  python3 - "$tmp/slab.json" crates/derma-optics/tests/data/iad_cases.json <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
ad = next(c for c in json.load(open(sys.argv[2]))["cases"] if c["name"] == "1 layer albedo 0.99 g 0.9 n 1.4 in air")
se = r["stderr"]
for what, mc, ref, s in [("R", r["r_specular"] + r["r_diffuse"], ad["r_total"], se["r_diffuse"]),
                         ("T", r["t_total"], ad["t_total"], se["t_total"])]:
    print(f"  {what} {mc:.6f} vs adding-doubling {ref:.6f}: diff {mc - ref:+.2e} = {(mc - ref) / s:+.1f} standard errors")
PY
done

# 2. The skin specimen (4 layers, 41 wavelengths, BRDF, profile, per-chromophore tallies).
"$derma" -q optics simulate --photons "$skin" --device gpu --json >"$tmp/skin.json"
python3 - "$tmp/skin.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
print(f"derma skin specimen gpu: {r['config']['photons'] / r['seconds']:.3e} photons/s ({r['seconds']:.2f} s)")
PY

# 3. Exemplar synthesis from the 256² crop; the CPU's file compared at the smallest size.
for s in "${sizes[@]}"; do
  m=$("$derma" synth -q -vv --exemplar "$ex/$exname.png" --size "$s" --device gpu --out "$tmp/g.png" \
    --metrics 2>"$tmp/synth.log")
  echo "derma synth gpu ${s}² from $exname: $m"
  # Where the time goes: each stage, and per optimisation pass the host's queries and weights,
  # the search and the E-step (its preparation and uploads, and the blend).
  grep -E "INFO.*(patch pass|optimisation|correction)|queries|E-step on the GPU" "$tmp/synth.log" \
    | sed -E 's/\x1b\[[0-9;]*m//g; s/^.*(INFO|DEBUG) [a-z_:]*: /  /' || true
  if [ "$s" = "${sizes[0]}" ]; then
    "$derma" synth -q --exemplar "$ex/$exname.png" --size "$s" --device cpu --out "$tmp/c.png"
    cmp -s "$tmp/g.png" "$tmp/c.png" && echo "synth ${s}²: GPU and CPU files identical" \
      || echo "synth ${s}²: FILES DIFFER"
  fi
done

# 4. The rig's GPU frame (criterion; frames back to back, nothing read back).
if [ -n "${RIG_BENCH:-}" ]; then
  "$RIG_BENCH" --bench "$frames_filter" --sample-size 20 2>&1 | grep -E "rig_gpu_frame|time:|skipped"
else
  echo "rig GPU frame: skipped (set RIG_BENCH)"
fi

# 4b. The optics kernel's layouts (workgroups, photons per thread, Philox products).
if [ -n "${LAYOUT_BENCH:-}" ]; then
  if [ "$quick" = 1 ]; then export PHOTONS=100000; fi
  "$LAYOUT_BENCH" --bench --sample-size 10 --warm-up-time 1 --measurement-time 3 2>&1 \
    | grep -E "^gpu_photons|thrpt:|skipped" | grep -v "%\]"
else
  echo "optics kernel layouts: skipped (set LAYOUT_BENCH)"
fi

# 5. MCX on the same slab: 0.05 mm voxels, 20 × 20 mm, 1 mm deep, refractive mismatch, a pencil
#    beam at the centre; pmcx's own kernel time and the call's wall time.
if [ -n "${PMCX_WHEELS:-}" ]; then
  python3 -c "import numpy" 2>/dev/null && need=(pmcx) || need=(pmcx numpy)
  python3 -m pip install -q --no-index --no-deps --find-links "$PMCX_WHEELS" --target "$tmp/site" "${need[@]}"
  export PYTHONPATH="$tmp/site${PYTHONPATH:+:$PYTHONPATH}"
fi
python3 - "$mcx_n" <<'PY' || echo "MCX: not run (pmcx or a CUDA device is missing)"
import sys, time
import numpy as np
import pmcx
n = int(sys.argv[1])
vol = np.ones((400, 400, 20), dtype="uint8")           # 0.05 mm voxels: 20 × 20 × 1 mm
prop = np.array([[0, 0, 1, 1], [0.1, 10.0, 0.9, 1.4]])  # per mm: μa, μs, g, n (medium 0: air)
t0 = time.time()
res = pmcx.run(nphoton=n, vol=vol, prop=prop, unitinmm=0.05, tstart=0, tend=5e-9, tstep=5e-9,
               srcpos=[200, 200, 0], srcdir=[0, 0, 1], issrcfrom0=1, isreflect=1,
               isspecular=1, autopilot=1, outputtype="energy")
wall = time.time() - t0
st = res["stat"]
kernel_s = st["runtime"] / 1000.0
absorbed = st["energyabs"] / st["energytot"]
print(f"MCX (pmcx {pmcx.__version__}) slab: {n / kernel_s:.3e} photons/s kernel, "
      f"{n / wall:.3e} wall; absorbed {absorbed:.4f} of the launched energy")
PY
