#!/usr/bin/env bash
# Builds the web viewer (viewer/, three.js + Vite from npm), generates a face with its rig
# (`derma skin`, `derma rig build --builtin all`, `derma export web`), serves it with `derma view`
# and runs scripts/viewer_test.mjs in Debian's chromium through playwright-core (both installed
# here when missing). Run by scripts/test.sh. SHOT=FILE.png keeps the screenshot.
set -euo pipefail
cd "$(dirname "$0")/.."
install() {
  apt-get install -y "$@" || { apt-get update && apt-get install -y "$@"; }
}
command -v npm >/dev/null 2>&1 || install nodejs npm
. scripts/common.sh
derma_lint_build
command -v chromium >/dev/null 2>&1 || install chromium
work=$(mktemp -d)
server=
cleanup() {
  [ -n "$server" ] && kill "$server" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
# The viewer's packages reinstalled only when its lock file changed; playwright-core installed
# once into target/ (both kept between runs).
stamp=viewer/node_modules/.derma-lock.sha256
sha256sum viewer/package-lock.json | cmp -s - "$stamp" || {
  npm --prefix viewer ci --silent --no-audit --no-fund
  sha256sum viewer/package-lock.json > "$stamp"
}
npm --prefix viewer run build --silent >/dev/null
pw=target/peer-viewer
npm_peer "$pw" playwright-core@1.65.1
# The workspace feature set of the test command, so its build is reused.
cargo build --release -q --workspace --exclude derma-py --bins --examples --all-features
d=target/release/derma
"$d" skin --size 512 --age 60 --out "$work/skin" --quiet
"$d" rig build --set "$work/skin" \
  --builtin all --radius 8 --out "$work/rig" --quiet
"$d" rig eval --rig "$work/rig" --out "$work/neutral.png" --quiet
"$d" rig eval --rig "$work/rig" --weights happiness=1 --out "$work/happy.png" --quiet
"$d" export web "$work/skin" --rig "$work/rig" --out "$work/web" --quiet
"$d" view "$work/web" --port 0 > "$work/view.log" &
server=$!
for _ in $(seq 100); do grep -q http "$work/view.log" 2>/dev/null && break; sleep 0.1; done
url=$(grep -o 'http://[^ ]*' "$work/view.log")
node scripts/viewer_test.mjs "$PWD/$pw" "$url" "$work/neutral.png" "$work/happy.png" \
  "${SHOT:-$work/viewer.png}"
