# Sourced by bench scripts after `cd` to the repository root: builds the release CLI and sets
# D (its path) and W (a scratch directory removed on exit).
cargo build --release -q -p derma
D=target/release/derma
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
