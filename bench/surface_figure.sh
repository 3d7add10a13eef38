#!/usr/bin/env bash
# docs/images/surface-fit.png (docs/matching.md): the built-in head with the authored surface
# (material.fitted_surface = false: roughness 0.6, F0 0.028) and with the match table's fit of the
# Monte Carlo surface, under the studio and window setups, forehead and eyes cropped and labelled.
# Needs python3 with Pillow.
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release -q -p derma
D=target/release/derma
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
printf '[material]\nfitted_surface = false\n' > "$W/authored.toml"
$D skin --size 2048 --seed 1 --config "$W/authored.toml" --out "$W/authored" -q
$D skin --size 2048 --seed 1 --out "$W/fitted" -q
for s in authored fitted; do
  $D render "$W/$s" --size 1024 --lighting studio,window --out "$W/$s-render" -q
done
python3 - "$W" <<'PY'
import sys
from PIL import Image, ImageDraw
d = sys.argv[1]
tiles = [(s, l) for l in ("studio", "window") for s in ("authored", "fitted")]
box = (192, 60, 832, 780)
ims = [Image.open(f"{d}/{s}-render/{l}.png").convert("RGB").crop(box) for s, l in tiles]
ims = [im.resize((im.width * 3 // 5, im.height * 3 // 5), Image.LANCZOS) for im in ims]
w, h = ims[0].size
out = Image.new("RGB", (w * len(ims), h), (12, 12, 14))
draw = ImageDraw.Draw(out)
names = {"authored": "authored: roughness 0.6, F0 0.028", "fitted": "fitted: roughness 0.857, F0 0.056"}
for i, (im, (s, l)) in enumerate(zip(ims, tiles)):
    out.paste(im, (i * w, 0))
    for k, text in enumerate((l, names[s])):
        b = draw.textbbox((i * w + 8, 6 + 14 * k), text)
        draw.rectangle((b[0] - 3, b[1] - 2, b[2] + 3, b[3] + 2), fill=(12, 12, 14))
        draw.text((i * w + 8, 6 + 14 * k), text, fill=(235, 235, 235))
out.save("docs/images/surface-fit.png", optimize=True)
PY
echo docs/images/surface-fit.png
