#!/usr/bin/env bash
# The viewer's README figures (docs/images/viewer.png and viewer-eyes.png): runs the browser
# test (scripts/viewer_test.sh) keeping its screenshot and, with EYESHOT set, crops of both eyes
# at gaze up 20°, ahead, down 25°, left 25° and aperture −0.5, which it stacks and labels.
# Needs python3 with Pillow.
set -euo pipefail
cd "$(dirname "$0")/.."
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
SHOT=docs/images/viewer.png EYESHOT="$W/eyes" bash scripts/viewer_test.sh
python3 - "$W" <<'PY'
import sys
from PIL import Image, ImageDraw
d = sys.argv[1]
shots = [("up", "gaze up 20°"), ("ahead", "ahead"), ("down", "gaze down 25°"),
         ("left", "gaze left 25°"), ("half", "aperture -0.5")]
ims = [Image.open(f"{d}/eyes-{n}.png").convert("RGB") for n, _ in shots]
w, h = ims[0].size
out = Image.new("RGB", (w, h * len(ims)), (12, 12, 14))
draw = ImageDraw.Draw(out)
for i, (im, (_, label)) in enumerate(zip(ims, shots)):
    out.paste(im, (0, i * h))
    draw.text((10, i * h + 8), label, fill=(20, 20, 20))
out.save("docs/images/viewer-eyes.png", optimize=True)
print("docs/images/viewer-eyes.png", out.size)
PY
