#!/usr/bin/env bash
# The optics against MCML 1.2.2 itself, per core, in one run: builds MCML (Wang, Jacques & Zheng
# 1995) from its public source — the authors' repository github.com/lhvwang/MCML, V1/mcR5unix/
# mcmlcode, never vendored — with gcc -O3, then times it and `derma optics slab` on one thread
# each on the three anchor slabs of ../shared/docs/SKIN-OPTICS-REFERENCES.md.
#   bash bench/mcml.sh                  (clones the repository into target/peer/MCML)
#   MCML_SRC=DIR bash bench/mcml.sh     (DIR: an existing checkout of that repository)
# Prints photons/s per core for both and the ratio; MCML's own tally grid is small (10 × 50 × 10)
# so its cost is the walk, as derma's (which keeps totals only).
set -euo pipefail
cd "$(dirname "$0")/.."
peer=target/peer/mcml-1.2.2
src=${MCML_SRC:-target/peer/MCML}
if [ ! -d "$src/V1/mcR5unix/mcmlcode" ]; then
  git clone --depth 1 https://github.com/lhvwang/MCML "$src"
fi
mkdir -p "$peer"
cc -O3 -w -o "$peer/mcml" "$src"/V1/mcR5unix/mcmlcode/mcml{main,go,io,nr}.c -lm
cargo build --release -q -p derma
derma=target/release/derma
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"

# name | MCML photons | MCML layers ("n mua mus g d_cm" lines) | n above/below | derma --layer args
cases=(
  "vdhulst|4000000|1.0 10 90 0.75 0.02|1.0|0.2,10,90,0.75,1.0"
  "slab1|1000000|1.4 1 100 0.9 0.1|1.0|1,1,100,0.9,1.4"
  "slab2|1000000|1.4 10 400 0.85 0.01;1.4 1 200 0.8 0.1|1.0|0.1,10,400,0.85,1.4 1,1,200,0.8,1.4"
)
printf "%-8s %14s %14s %8s\n" case "MCML /s/core" "derma /s/core" ratio
for c in "${cases[@]}"; do
  IFS='|' read -r name photons layers ambient dlayers <<<"$c"
  IFS=';' read -r -a ls <<<"$layers"
  mci="$peer/$name.mci"
  {
    echo "1.0"
    echo "1"
    echo "$peer/$name.mco A"
    echo "$photons"
    echo "0.01 0.01"
    echo "10 50 10"
    echo "${#ls[@]}"
    echo "$ambient"
    for l in "${ls[@]}"; do echo "$l"; done
    echo "$ambient"
  } >"$mci"
  t0=$(date +%s.%N)
  "$peer/mcml" "$mci" >/dev/null
  t1=$(date +%s.%N)
  args=()
  for l in $dlayers; do args+=(--layer "$l"); done
  d_rate=$(RAYON_NUM_THREADS=1 "$derma" optics slab "${args[@]}" --above "$ambient" \
    --below "$ambient" --photons 4000000 --device cpu --json |
    python3 -c "import json, sys; print(json.load(sys.stdin)['photons_per_s'])")
  python3 -c "
m = $photons / ($t1 - $t0); d = $d_rate
print(f'{\"$name\":8s} {m:14.3e} {d:14.3e} {d / m:7.1f}x')"
done
