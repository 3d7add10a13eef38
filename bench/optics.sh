#!/usr/bin/env bash
# Photon throughput of `derma optics` on the MCML anchor slabs and the skin specimen.
# Usage: bench/optics.sh [cpu|gpu|both]   (prints one line per case: photons/s and results)
# Anchors (SKIN-OPTICS-REFERENCES): MCML 1.2.2, gcc -O3, one core of a 2-core EPYC: 3.7e6/s on
# the van de Hulst slab, 3.6e5/s on the 1-layer slab, 1.4e5/s on the 2-layer slab, 2.6e4/s on its
# 7-layer skin model (recorded anchors; `bench/mcml.sh` builds MCML 1.2.2 from its
# public source and times it beside derma on this one).
set -euo pipefail
cd "$(dirname "$0")/.."
which="${1:-both}"
cargo build --release -q -p derma --features gpu
bin=target/release/derma
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
devices=()
[[ "$which" == cpu || "$which" == both ]] && devices+=(cpu)
[[ "$which" == gpu || "$which" == both ]] && devices+=(gpu)
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
for dev in "${devices[@]}"; do
  n=4000000; [[ $dev == gpu ]] && n=20000000
  for case in "vdH|0.2,10,90,0.75,1" "1-layer|1,1,100,0.9,1.4" "2-layer|0.1,10,400,0.85,1.4 1,1,200,0.8,1.4"; do
    name="${case%%|*}"; spec="${case#*|}"
    args=(); for l in $spec; do args+=(--layer "$l"); done
    "$bin" -q optics slab "${args[@]}" --photons "$n" --device "$dev" --json 2>/dev/null \
      | python3 -c "import json,sys; r=json.load(sys.stdin); print(f\"$dev $name: {r['photons_per_s']:.3e} photons/s  R={r['r_specular']+r['r_diffuse']:.5f} T={r['t_total']:.5f} A={r['absorbed']:.5f}\")"
  done
  m=1000000; [[ $dev == gpu ]] && m=4100000
  "$bin" -q optics simulate --photons "$m" --device "$dev" --json 2>/dev/null \
    | python3 -c "import json,sys; r=json.load(sys.stdin); print(f\"$dev skin (4 layers, 41 wavelengths, all tallies): {r['config']['photons']/r['seconds']:.3e} photons/s  albedo sRGB {[round(c,4) for c in r['linear_srgb']]}\")"
done
