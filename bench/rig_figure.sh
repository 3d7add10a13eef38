#!/usr/bin/env bash
# The README's expression figure (docs/images/rig-expressions.png): the built-in head painted by
# `derma skin`, rigged with the built-in library, under the neutral pose and each entry, with
# its hemoglobin map beside it (dark = more blood, as Jimenez et al. 2010 fig. 2).
# Needs python3 with Pillow to tile the panels.
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/common.sh
$D skin --size 1024 --seed 1 --out "$W/skin" -q
$D rig build --set "$W/skin" --builtin all --radius 24 --out "$W/rig" -q
NAMES="neutral happiness sadness anger fear surprise disgust exercise alcohol"
for n in $NAMES; do
  w=""; [ "$n" != neutral ] && w="$n=1"
  $D rig eval --rig "$W/rig" --weights "$w" --preview "$W/$n.png" > /dev/null
done
python3 - "$W" $NAMES <<'PY'
import sys
from PIL import Image, ImageDraw
d, names = sys.argv[1], sys.argv[2:]
ims = [Image.open(f"{d}/{n}.png").convert("RGB") for n in names]
w, h = ims[0].size
cols = 3
sheet = Image.new("RGB", (cols * w // 2, ((len(ims) + cols - 1) // cols) * (h // 2 + 18)), (12, 12, 12))
for i, (n, im) in enumerate(zip(names, ims)):
    x, y = (i % cols) * w // 2, (i // cols) * (h // 2 + 18)
    sheet.paste(im.resize((w // 2, h // 2), Image.LANCZOS), (x, y + 18))
    ImageDraw.Draw(sheet).text((x + 8, y + 3), n, fill=(230, 230, 230))
sheet.save("docs/images/rig-expressions.png", optimize=True)
print("wrote docs/images/rig-expressions.png", sheet.size)
PY
