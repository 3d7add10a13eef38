#!/usr/bin/env bash
# The project's test command (README.md; CI runs it on a fresh machine): installs what the tests
# need; checks formatting and lints; checks the committed adding-doubling references against
# iadpython and the histogram-matching reference against scikit-image; checks deploy/; runs the
# workspace tests with the `gpu` feature and the GPU tests required (on Mesa's lavapipe); validates the exported GLBs with
# Khronos' glTF-Validator; runs every numbered example; builds the Python wheel, installs it in
# a fresh virtual environment and runs its tests; and drives the web viewer in headless
# Chromium (scripts/viewer_test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then
  apt-get install -y mesa-vulkan-drivers || { apt-get update && apt-get install -y mesa-vulkan-drivers; }
fi
python3 -m pip install --quiet iadpython scipy scikit-image
for c in clippy rustfmt; do
  rustup component list --installed 2>/dev/null | grep -q "^$c" || rustup component add "$c"
done
cargo fmt --all -- --check
# Both builds: the default (CPU only, what `cargo run -p derma` makes) and the GPU one.
cargo clippy --workspace --all-targets -- -D warnings
cargo clippy --workspace --all-targets --all-features -- -D warnings
python3 scripts/iad_reference.py --check
python3 scripts/histmatch_reference.py --check
# The cluster deployment files parse and validate (Slurm scripts, Kubernetes manifests).
bash deploy/check.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
DERMA_REQUIRE_GPU=1 cargo test --workspace --release --all-features
# The default build's device choice (no GPU compiled in: `auto` is the CPU, `gpu` a clear error).
cargo test --release -q -p derma-core --lib gpu::tests
# The exported head opens without errors or warnings in Khronos' glTF-Validator.
bash scripts/validate_gltf.sh
# Every numbered example runs (the Monte Carlo ones with fewer photons than their defaults),
# built once with the workspace's features (a per-crate `cargo run -p` would rebuild its
# dependencies with another feature set).
cargo build --release -q --workspace --bins --examples --all-features
tmp=$(mktemp -d)
for f in crates/*/examples/[0-9][0-9]_*.rs; do
  ex=$(basename "$f" .rs)
  case "$ex" in
    01_skin_spectra) args=("$tmp/spectra.svg" 41000) ;;
    02_appearance_check) args=(3 41000) ;;
    *) args=() ;;
  esac
  echo "example $ex"
  "target/release/examples/$ex" "${args[@]}" > "$tmp/$ex.log" 2>&1 || { cat "$tmp/$ex.log"; exit 1; }
done
# The Python package: the abi3 wheel built from this tree by maturin (with the GPU backends, as
# the workspace's tests just built them), installed into a fresh virtual environment, used as a
# user would, its stubs checked against the module (mypy's stubtest), and its pytest tests.
python3 -m pip install --quiet "maturin>=1.5,<2"
rm -rf target/wheels target/py-venv
python3 -m maturin build --release --quiet -m crates/derma-py/Cargo.toml -o target/wheels
python3 -m venv target/py-venv
target/py-venv/bin/pip install --quiet target/wheels/derma-*.whl pytest mypy
py=$PWD/target/py-venv/bin/python
(cd "$tmp" && "$py" -c "import derma; s = derma.skin(size=256); print(s['base_color'].shape)")
(cd "$tmp" && "$py" -m mypy.stubtest derma._derma)
DERMA_CLI=$PWD/target/release/derma "$py" -m pytest -q -p no:cacheprovider crates/derma-py/tests
rm -rf "$tmp"
# The web viewer in Debian's chromium: the GLB loads, the smile slider flushes the cheeks.
bash scripts/viewer_test.sh
