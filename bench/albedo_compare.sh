#!/usr/bin/env bash
# derma's skin beside two real scans' photographed albedo (docs/skin.md, "Beside a real face";
# S0 §6.2): each scan of scripts/corpus.py with a texture — Lee Perry-Smith (the one the
# regional biology was tuned on) and Jon Cole (held out) — fitted with `derma head fit`, painted
# on its own UVs at the scan's own tone (its ITA° on cheeks and forehead, as --compare-albedo
# prints it) and compared region by region. Fetches the scans when target/corpus lacks them
# (CORPUS_FROM=DIR: take their files from DIR, as `corpus.py fetch --from`). OUT=DIR keeps the
# sets and renders (the README's side-by-side: bench/albedo_figure.py).
#   bash bench/albedo_compare.sh
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/common.sh
corpus=target/corpus
out=${OUT:-$W}
for name in leeperrysmith jon; do
  [ -f "$corpus/$name.obj" ] || python3 scripts/corpus.py fetch --only "$name" ${CORPUS_FROM:+--from "$CORPUS_FROM"}
done
echo "machine: $(nproc) cores, $(date -u +%F)"
run() { # NAME ALBEDO SIZE
  local name=$1 albedo=$corpus/$2 size=$3
  $D head fit --mesh "$corpus/$name.obj" --out "$out/$name-fit" -q
  # The scan's own tone: a first pass reads it off the photo.
  local ita
  ita=$($D skin --mesh "$corpus/$name.obj" --head "$out/$name-fit" --sex male --size 256 \
    --out "$out/$name-tone" -q --compare-albedo "$albedo" 2>/dev/null |
    sed -n 's/.*the photo.s ITA \([-0-9]*\)° on cheeks and forehead.*/\1/p')
  echo "## $name (ITA $ita°, male, age 35, seed 1, ${size}²)"
  $D skin --mesh "$corpus/$name.obj" --head "$out/$name-fit" --sex male --ita "$ita" \
    --size "$size" --out "$out/$name-set" -q --compare-albedo "$albedo" 2>/dev/null
}
run leeperrysmith Map-COL.jpg 1024
run jon jon.jpg 2048
