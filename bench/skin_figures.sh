#!/usr/bin/env bash
# The skin figures of README.md and docs/head.md: the default head's preview (`derma skin`, 2048²:
# docs/images/skin-preview-head.png), a tileable patch's (`--patch 30 --size 1024`:
# skin-preview-patch.png), and the 4096² close-up (skin-closeup-4096.png): a 512-texel crop of
# the base colour and the normal map centred on the left eye (the centroid of the `eyelids`
# region's mask on the image's left half, from --export-template), side by side; the 4096²
# eyebrow close-up (skin-eyebrow-4096.png: base colour, normal and hair_coverage.png around the
# centroid of the left `eyebrows` mask); and the six skin-tone presets side by side
# (skin-presets.png: `derma skin --preset P`, 1024², for the ITA° categories of Chardon et al.
# 1991, each drawn by `derma render --lighting studio` on the GPU renderer, lavapipe where there
# is no GPU: brows, lashes and the male default's stubble). Needs python3 with Pillow.
set -euo pipefail
cd "$(dirname "$0")/.."
FEATURES=gpu source bench/common.sh
$D skin --seed 1 --out "$W/head" -q
cp "$W/head/preview.png" docs/images/skin-preview-head.png
$D skin --patch 30 --size 1024 --seed 1 --out "$W/patch" -q
cp "$W/patch/preview.png" docs/images/skin-preview-patch.png
$D skin --size 4096 --seed 1 --out "$W/set" -q
$D skin --export-template "$W/tpl" -q
python3 - "$W" <<'PY'
import sys
from PIL import Image
d = sys.argv[1]

def centroid(region):
    """The centroid, in 4096² texels, of a region mask's strong part on the image's left half."""
    m = Image.open(f"{d}/tpl/{region}.png").convert("F")
    w, h = m.size
    px = m.load()
    sx = sy = s = 0.0
    for y in range(h):
        for x in range(w // 2):
            v = px[x, y]
            if v > 0.5 * 65535:
                sx += x * v; sy += y * v; s += v
    return int(sx / s * 4096 / w), int(sy / s * 4096 / h)

cx, cy = centroid("eyelids")
box = (cx - 256, cy - 256, cx + 256, cy + 256)
sheet = Image.new("RGB", (1024, 512))
for i, name in enumerate(["base_color", "normal"]):
    sheet.paste(Image.open(f"{d}/set/{name}.png").convert("RGB").crop(box), (512 * i, 0))
sheet.save("docs/images/skin-closeup-4096.png")
print("wrote docs/images/skin-closeup-4096.png, crop", box)
# The left eyebrow: 640 × 320 texels (about 40 × 20 mm) around its mask's centroid.
cx, cy = centroid("eyebrows")
box = (cx - 320, cy - 160, cx + 320, cy + 160)
sheet = Image.new("RGB", (640, 960))
for i, name in enumerate(["base_color", "normal", "hair_coverage"]):
    sheet.paste(Image.open(f"{d}/set/{name}.png").convert("RGB").crop(box), (0, 320 * i))
sheet.save("docs/images/skin-eyebrow-4096.png")
print("wrote docs/images/skin-eyebrow-4096.png, crop", box)
PY
PRESETS="very-light light intermediate tan brown dark"
for p in $PRESETS; do
  $D skin --size 1024 --seed 1 --preset "$p" --out "$W/$p" -q
  $D render "$W/$p" --lighting studio --size 768 --device gpu --out "$W/$p/render" -q
done
python3 - "$W" $PRESETS <<'PY'
import sys, json
from PIL import Image, ImageDraw
d, names = sys.argv[1], sys.argv[2:]
panels = []
for n in names:
    im = Image.open(f"{d}/{n}/render/studio.png").convert("RGB")
    panels.append(im.crop((144, 40, 624, 728)))
w, h = panels[0].size
sheet = Image.new("RGB", (w * len(panels), h + 20), (12, 12, 12))
for i, (n, im) in enumerate(zip(names, panels)):
    sheet.paste(im, (i * w, 20))
    ita = json.load(open(f"{d}/{n}/report.json"))["config"]["person"]["ita_deg"]
    ImageDraw.Draw(sheet).text((i * w + 8, 4), f"{n} (ITA {ita:.1f})", fill=(230, 230, 230))
sheet.save("docs/images/skin-presets.png")
print("wrote docs/images/skin-presets.png", sheet.size)
PY
