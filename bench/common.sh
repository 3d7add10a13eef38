# Sourced by bench scripts after `cd` to the repository root: builds the release CLI (with the
# cargo features in FEATURES, e.g. FEATURES=gpu, where a script needs them) and sets D (its
# path) and W (a scratch directory removed on exit).
cargo build --release -q -p derma ${FEATURES:+--features "$FEATURES"}
D=target/release/derma
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
