#!/usr/bin/env bash
# The project's test command (README.md; CI runs it on a fresh machine):
# installs what the tests need, checks the committed adding-doubling references against
# iadpython and the histogram-matching reference against scikit-image, and runs the workspace tests with the GPU tests required (on Mesa's lavapipe).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then
  apt-get install -y mesa-vulkan-drivers || { apt-get update && apt-get install -y mesa-vulkan-drivers; }
fi
python3 -m pip install --quiet iadpython scipy scikit-image
python3 scripts/iad_reference.py --check
python3 scripts/histmatch_reference.py --check
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
DERMA_REQUIRE_GPU=1 cargo test --workspace --release
