#!/usr/bin/env bash
# The skin-tone figure (docs/images/skin-presets.png): `derma skin --preset P` for the six ITA°
# presets of Chardon et al. 1991, front views from each preview, side by side.
# Needs python3 with Pillow to tile the panels.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p derma
D=target/release/derma
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
PRESETS="very-light light intermediate tan brown dark"
for p in $PRESETS; do
  $D skin --size 1024 --seed 1 --preset "$p" --out "$W/$p" -q
done
python3 - "$W" $PRESETS <<'PY'
import sys, json
from PIL import Image, ImageDraw
d, names = sys.argv[1], sys.argv[2:]
panels = []
for n in names:
    im = Image.open(f"{d}/{n}/preview.png").convert("RGB")
    panels.append(im.crop((40, 0, 472, 512)))
w, h = panels[0].size
sheet = Image.new("RGB", (w * len(panels), h + 20), (12, 12, 12))
for i, (n, im) in enumerate(zip(names, panels)):
    sheet.paste(im, (i * w, 20))
    ita = json.load(open(f"{d}/{n}/report.json"))["config"]["person"]["ita_deg"]
    ImageDraw.Draw(sheet).text((i * w + 8, 4), f"{n} (ITA {ita:.1f})", fill=(230, 230, 230))
sheet.save("docs/images/skin-presets.png")
print("wrote docs/images/skin-presets.png", sheet.size)
PY
