#!/usr/bin/env bash
# The Blender add-on (blender/derma_skin) on Debian's blender, headless: installs Blender and
# python3-numpy when missing, builds derma, then blender/test_addon.py installs the add-on from
# a zip, paints the built-in head through it, checks the material's wiring and the expression
# drivers, and renders 256² with Cycles (bench/out/blender/render.png). Then the same test on
# current Blender: the `bpy` module from PyPI (Blender 5.0.1 as a Python module, Cycles
# included) in its own virtual environment (bench/out/blender-current/).
#   bash bench/blender.sh            (DERMA_RES, DERMA_SAMPLES: the render's size and samples;
#                                     BLENDER_CURRENT=0 skips the second run)
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v blender >/dev/null || ! /usr/bin/python3 -c 'import numpy' 2>/dev/null; then
  apt-get install -y blender python3-numpy || { apt-get update && apt-get install -y blender python3-numpy; }
fi
cargo build --release -q -p derma
out=bench/out/blender
rm -rf "$out"
mkdir -p "$out"
export DERMA="$PWD/target/release/derma"
# Blender 3.4's importer and the add-on use numpy: Debian's python3-numpy, not a virtualenv's.
env -u VIRTUAL_ENV -u PYTHONPATH blender -b --factory-startup --python-exit-code 1 \
  --python blender/test_addon.py -- "$out" 2>&1 | tee "$out/log.txt" | grep -E "derma|Error|error|Traceback|assert" || true
grep -q "derma add-on test passed" "$out/log.txt"
if [ "${BLENDER_CURRENT:-1}" != 0 ]; then
  venv=target/peer-bpy
  [ -x "$venv/bin/python" ] || { python3 -m venv "$venv" && "$venv/bin/pip" install --quiet "bpy==5.0.1"; }
  cur=bench/out/blender-current
  rm -rf "$cur"
  mkdir -p "$cur"
  "$venv/bin/python" blender/test_addon.py -- "$cur" 2>&1 | tee "$cur/log.txt" \
    | grep -E "derma|Error|error|Traceback|assert" || true
  grep -q "derma add-on test passed" "$cur/log.txt"
fi
