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
box = (300, 80, 980, 840)
ims = [Image.open(f"{d}/{s}-render/{l}.png").convert("RGB").crop(box) for s, l in tiles]
w, h = ims[0].size
out = Image.new("RGB", (w * len(ims), h), (12, 12, 14))
draw = ImageDraw.Draw(out)
names = {"authored": "authored: roughness 0.6, F0 0.028", "fitted": "fitted: roughness 0.857, F0 0.056"}
for i, (im, (s, l)) in enumerate(zip(ims, tiles)):
    out.paste(im, (i * w, 0))
    text = f"{l} - {names[s]}"
    b = draw.textbbox((i * w + 10, 8), text)
    draw.rectangle((b[0] - 4, b[1] - 3, b[2] + 4, b[3] + 3), fill=(12, 12, 14))
    draw.text((i * w + 10, 8), text, fill=(235, 235, 235))
out = out.resize((out.width // 2, out.height // 2), Image.LANCZOS)
out.save("docs/images/surface-fit.png", optimize=True)
PY
echo docs/images/surface-fit.png
