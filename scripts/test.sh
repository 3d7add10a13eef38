#!/usr/bin/env bash
# The project's test command (README.md; CI runs it on a fresh machine). It installs what the
# tests need (each install skipped when present), checks formatting, then builds the workspace
# once with every feature — clippy's driver compiling the workspace's own crates, so the lints
# (-D warnings) come with the build that the tests, examples, benches, binaries, wheel and
# viewer then use — and the default (CPU-only) build of the CLI, linted the same way. It checks
# the committed adding-doubling references against iadpython and the histogram-matching
# reference against scikit-image; checks deploy/; runs the workspace tests with the GPU tests
# required (on Mesa's lavapipe) and the default build's device choice; validates the exported
# GLBs with Khronos' glTF-Validator; runs every numbered example; installs the Python wheel in
# a virtual environment and runs its tests. The slow checks (`#[ignore]`d tests and the web
# viewer in headless Chromium) run by scripts/test_slow.sh; docs/testing.md says which check runs
# where.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$SECONDS
phase() { echo "== $1 (at $((SECONDS - start)) s)"; }
phase installs
. scripts/common.sh
derma_installs
phase fmt
cargo fmt --all -- --check
# The lints come with the build (scripts/common.sh): clippy's driver compiles the workspace.
derma_lint_build
phase "build (default features: the CLI as README's first command builds it)"
# First, so that the build with every feature below leaves its binaries in target/release.
cargo build --release -q -p derma
# The default build's device choice (no GPU compiled in: `auto` is the CPU, `gpu` a clear error).
cargo test --release -q -p derma-core --lib gpu::tests
phase "build (every feature: libraries, binaries, tests, examples, benches)"
# derma-py is maturin's to build (below): its pyo3 is configured for the interpreter, and a
# cargo build beside it would build pyo3 a second way each run.
cargo build --release --workspace --exclude derma-py --all-features --benches
cargo test --release --workspace --exclude derma-py --all-features --no-run
phase references
python3 scripts/iad_reference.py --check
python3 scripts/histmatch_reference.py --check
# The cluster deployment files parse and validate (Slurm scripts, Kubernetes manifests).
bash deploy/check.sh
phase tests
DERMA_REQUIRE_GPU=1 cargo test --release --workspace --exclude derma-py --all-features
phase glTF-Validator
# The exported heads open without errors or warnings in Khronos' glTF-Validator.
bash scripts/validate_gltf.sh
phase examples
# Every numbered example runs (the Monte Carlo ones with fewer photons than their defaults).
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
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
phase "Python wheel"
# The Python package: the abi3 wheel built from this tree by maturin (with the GPU backends),
# installed into a virtual environment (kept between runs; the wheel itself reinstalled), used
# as a user would, its stubs checked against the module (mypy's stubtest), and its pytest tests.
python3 -m maturin --version >/dev/null 2>&1 || python3 -m pip install --quiet "maturin>=1.5,<2"
rm -rf target/wheels
python3 -m maturin build --release --quiet -m crates/derma-py/Cargo.toml -o target/wheels
venv=target/py-venv
"$venv/bin/python" -c "import pytest, mypy" 2>/dev/null || {
  rm -rf "$venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet pytest mypy
}
# The wheel itself anew, then its dependencies as its metadata names them.
"$venv/bin/pip" install --quiet --force-reinstall --no-deps target/wheels/derma-*.whl
"$venv/bin/pip" install --quiet target/wheels/derma-*.whl
py=$PWD/$venv/bin/python
(cd "$tmp" && "$py" -c "import derma; s = derma.skin(size=256); print(s['base_color'].shape)")
(cd "$tmp" && "$py" -m mypy.stubtest derma._derma)
DERMA_CLI=$PWD/target/release/derma "$py" -m pytest -q -p no:cacheprovider crates/derma-py/tests
phase done
