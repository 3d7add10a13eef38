#!/usr/bin/env bash
# Exports the built-in head (`derma skin --export-template`), an animated eye region (`derma
# eyes animate`), a texture set on the head (`derma skin --glb`), the same set with Unreal
# names and DirectX normals (`derma export glb`), a set on a user mesh (MediaPipe's canonical
# face from ../shared/data), and the head fitted to that face (`derma head fit`) with its set
# and its animated eyes, on the fitted head and on the face mesh itself, and checks every GLB with Khronos'
# glTF-Validator from npm (installed into target/peer-gltf, kept between runs, with Node.js from apt when
# the machine lacks it). Run by scripts/test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/common.sh
derma_lint_build
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Installed once into target/ (kept between runs; again for another version).
v=target/peer-gltf
npm_peer "$v" gltf-validator@2.0.0-dev.3.10
# The workspace feature set of the test command, so its build is reused.
cargo build --release -q --workspace --exclude derma-py --bins --examples --all-features
target/release/derma skin --export-template "$work/head" --quiet
target/release/derma eyes animate --seconds 1 --fps 10 --render 0 --out "$work/eyes" --quiet >/dev/null
target/release/derma skin --size 256 --glb --out "$work/skin" --quiet
target/release/derma export glb "$work/skin" --out "$work/unreal.glb" --maps "$work/unreal" \
  --names unreal --normal directx --quiet
target/release/derma skin --size 256 --glb --out "$work/user" --quiet \
  --mesh ../shared/data/canonical_face_model.obj --landmarks mediapipe
target/release/derma head fit --mesh ../shared/data/canonical_face_model.obj --landmarks mediapipe \
  --out "$work/fitted" --quiet >/dev/null
target/release/derma skin --size 256 --glb --head "$work/fitted" --out "$work/fitskin" --quiet
target/release/derma eyes animate --head "$work/fitted" --seconds 1 --fps 10 --render 0 \
  --out "$work/fiteyes" --quiet >/dev/null
target/release/derma eyes animate --head "$work/fitted" --mesh ../shared/data/canonical_face_model.obj \
  --seconds 1 --fps 10 --render 0 --out "$work/meshyes" --quiet >/dev/null
node scripts/validate_gltf.js "$PWD/$v" "$work/head/head.glb" "$work/eyes/head.glb" \
  "$work/skin/head.glb" "$work/unreal.glb" "$work/user/head.glb#static" \
  "$work/fitskin/head.glb" "$work/fiteyes/head.glb" "$work/meshyes/head.glb"
