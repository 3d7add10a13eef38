#!/usr/bin/env bash
# The expression sequence figure (docs/images/render-expression.png): a 2048² set of the
# built-in head at 60 years, its rig (`derma rig build --set`), and `derma render --rig` at four
# frames — neutral, happiness, surprise, anger — each coloured by the rig, posed by the
# expression's face units and folded by the expression wrinkles they drive (docs/rig.md), under
# the side-lit `window` setup that shows relief; then a crop of the forehead at rest and with
# the brows raised. Uses the GPU renderer (any adapter, lavapipe included). Needs python3 with
# Pillow to tile and label the frames.
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release -q -p derma --features gpu
D=target/release/derma
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
$D skin --size 2048 --seed 3 --age 60 --out "$W/set" -q
$D rig build --set "$W/set" --builtin all --radius 48 --out "$W/rig" -q
for e in neutral happiness surprise anger; do
  w=""
  [ "$e" = neutral ] || w="$e=1"
  $D render "$W/set" --rig "$W/rig" --weights "$w" --lighting window --size 768 --zoom 0.85 \
    --pitch 4 --device gpu --out "$W/$e" -q
done
for p in rest raised; do
  u=""
  [ "$p" = rest ] || u=browInnerUp=1,browOuterUpLeft=1,browOuterUpRight=1
  $D render "$W/set" --pose "$u" --lighting window --size 1024 --zoom 0.45 --pitch 12 \
    --device gpu --out "$W/brow-$p" -q
done
python3 - "$W" <<'PY'
import sys
from PIL import Image, ImageDraw
d = sys.argv[1]
names = ["neutral", "happiness", "surprise", "anger"]
frames = [Image.open(f"{d}/{n}/window.png").convert("RGB") for n in names]
w, h = frames[0].size
crops = [Image.open(f"{d}/brow-{p}/window.png").convert("RGB").crop((0, 0, 1024, 420))
         .resize((2 * w, 2 * w * 420 // 1024)) for p in ["rest", "raised"]]
ch = crops[0].height
out = Image.new("RGB", (4 * w, h + ch), (12, 12, 14))
draw = ImageDraw.Draw(out)
def label(x, y, text):
    box = draw.textbbox((x + 8, y + 6), text)
    draw.rectangle((box[0] - 4, box[1] - 3, box[2] + 4, box[3] + 3), fill=(12, 12, 14))
    draw.text((x + 8, y + 6), text, fill=(235, 235, 235))
for i, (n, f) in enumerate(zip(names, frames)):
    out.paste(f, (i * w, 0))
for i, c in enumerate(crops):
    out.paste(c, (i * 2 * w, h))
for i, n in enumerate(names):
    label(i * w, 0, n if n == "neutral" else f"{n} = 1 (rig colour, face units, wrinkles)")
label(0, h, "forehead at rest")
label(2 * w, h, "brows raised: browInnerUp, browOuterUp = 1")
out.save("docs/images/render-expression.png")
print("wrote docs/images/render-expression.png", out.size)
PY
