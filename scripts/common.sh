# Sourced by the test scripts (test.sh, test_slow.sh, validate_gltf.sh, viewer_test.sh): what
# they install when missing and the one build they share.
#
# derma_installs: Mesa's lavapipe (the GPU tests' adapter), iadpython / SciPy / scikit-image
# (the references' checks), clippy and rustfmt; each skipped when present.
derma_installs() {
  if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then
    apt-get install -y mesa-vulkan-drivers || { apt-get update && apt-get install -y mesa-vulkan-drivers; }
  fi
  python3 -c "import iadpython, scipy, skimage" 2>/dev/null ||
    python3 -m pip install --quiet iadpython scipy scikit-image
  for c in clippy rustfmt; do
    rustup component list --installed 2>/dev/null | grep -q "^$c" || rustup component add "$c"
  done
}

# The lints come with the build: cargo runs clippy's driver in place of rustc on the workspace's
# crates (as `cargo clippy` does), here for a build that makes code, denying warnings. Every
# script exports the same, so each reuses the others' build (the wrapper is part of what cargo
# fingerprints).
derma_lint_build() {
  command -v clippy-driver >/dev/null 2>&1 ||
    [ -x "$(rustc --print sysroot)/bin/clippy-driver" ] ||
    rustup component add clippy
  RUSTC_WORKSPACE_WRAPPER="$(rustc --print sysroot)/bin/clippy-driver"
  CLIPPY_ARGS="-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"
  XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
  export RUSTC_WORKSPACE_WRAPPER CLIPPY_ARGS XDG_RUNTIME_DIR
}

# npm_peer DIR PACKAGE@VERSION: installs a test's npm package into DIR (kept between runs), again
# when the version asked for is not the one there or an install was cut short.
npm_peer() {
  local dir=$1 spec=$2 name=${2%@*} version=${2##*@}
  command -v npm >/dev/null 2>&1 ||
    apt-get install -y nodejs npm || { apt-get update && apt-get install -y nodejs npm; }
  local have
  have=$(node -p "require('$PWD/$dir/node_modules/$name/package.json').version" 2>/dev/null || true)
  if [ "$have" != "$version" ]; then
    rm -rf "$dir"
    npm install --silent --no-audit --no-fund --prefix "$dir" "$spec" >/dev/null
  fi
}
