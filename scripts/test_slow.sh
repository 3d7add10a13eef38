#!/usr/bin/env bash
# The slow checks, outside the test command (scripts/test.sh) to keep it short: every test marked
# `#[ignore = "slow: scripts/test_slow.sh"]` (the photo ground truth, the head fit's truth and
# refusals, the sharded batch's kill-and-resume, the README's and docs' command lines, the
# regional colour and presets, the optics' spectra and reciprocity, …) and the docs' slow lines
# (`doc_commands`: precompute, match fit and LUT, photo bake, head fit, the eye model), with the
# GPU tests required on Mesa's lavapipe; and the web viewer in headless Chromium
# (scripts/viewer_test.sh: the GLB loads, the smile slider flushes the cheeks, the eye model's
# JavaScript port agrees with derma's evaluator). The corpus fits need downloaded scans and run by their
# own command (docs/head.md). docs/testing.md lists which check runs where.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/common.sh
derma_installs
# The same lints-with-the-build as scripts/test.sh, so each reuses the other's build.
derma_lint_build
DERMA_REQUIRE_GPU=1 cargo test --release --workspace --exclude derma-py --all-features -- --ignored \
  --skip corpus::the_corpus_is_fitted_with_no_flags --skip corpus_face_units::
# The web viewer (software-rendered Chromium: about 2 min 40 s).
bash scripts/viewer_test.sh
