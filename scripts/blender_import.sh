#!/usr/bin/env bash
# Opens derma's exported GLB in Blender's own glTF importer: Debian's blender (installed here
# when missing, with the numpy its importer needs) imports the skin set's head.glb and
# scripts/blender_import.py checks the named meshes, the face units as shape keys and the skin
# material's maps. RENDER=FILE.png also renders it with Cycles. Not part of the test command
# (the install is large); docs/render.md records its last result.
# Usage: bash scripts/blender_import.sh [GLB]   (default: a fresh 512² set on the built-in head)
set -euo pipefail
cd "$(dirname "$0")/.."
install() {
  apt-get install -y "$@" || { apt-get update && apt-get install -y "$@"; }
}
command -v blender >/dev/null 2>&1 || install blender
[ -d /usr/lib/python3/dist-packages/numpy ] || install python3-numpy
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
glb=${1:-}
if [ -z "$glb" ]; then
  cargo build --release -q --workspace --bins --all-features
  target/release/derma skin --size 512 --glb --out "$work/skin" --quiet
  glb="$work/skin/head.glb"
fi
blender --version | head -1
blender -b --python-exit-code 1 --python scripts/blender_import.py -- "$glb" \
  skin eye_left eye_right teeth_upper teeth_lower tongue 2>&1 |
  grep -v -e '^$' -e 'FutureWarning' -e 'numpy.bool = bool'
