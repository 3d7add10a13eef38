#!/usr/bin/env bash
# The README figure docs/images/synth-comparison.png from bench/synth.sh's 512² outputs: per
# exemplar, the exemplar (native size), derma synth and Embark's texture-synthesis, side by side.
# Grey rows are stretched linearly by the exemplar's 1st–99th percentile, the same for all three.
set -euo pipefail
cd "$(dirname "$0")/.."
out=bench/out/synth
python3 - "$out" docs/images/synth-comparison.png <<'PY'
import sys
from PIL import Image, ImageDraw
src, dst = sys.argv[1], sys.argv[2]
cell, pad, label_h = 384, 8, 22
rows = ["disp128", "disp256", "albedo128", "albedo256x128"]
cols = ["exemplar", "derma synth", "texture-synthesis (peer)"]
fig = Image.new("RGB", (3 * cell + 4 * pad, len(rows) * (cell + label_h + pad) + pad), "white")
draw = ImageDraw.Draw(fig)
for r, ex in enumerate(rows):
    def load(path):
        im = Image.open(path)
        if im.mode in ("I", "I;16"):  # 16-bit grey (derma writes single channels so): to 8 bits
            im = im.convert("I").point(lambda v: v * (1 / 257)).convert("L")
        return im
    e = load(f"{src}/{ex}.png")
    grey = e.mode == "L"
    imgs = [e, load(f"{src}/{ex}_512_derma.png"), load(f"{src}/{ex}_512_peer.png")]
    if grey:
        vals = sorted(e.convert("L").tobytes())
        lo, hi = vals[len(vals) // 100], vals[len(vals) * 99 // 100]
        lut = [max(0, min(255, round((v - lo) * 255 / max(1, hi - lo)))) for v in range(256)]
        imgs = [i.convert("L").point(lut).convert("RGB") for i in imgs]
    else:
        imgs = [i.convert("RGB") for i in imgs]
    y = pad + r * (cell + label_h + pad)
    for c, im in enumerate(imgs):
        x = pad + c * (cell + pad)
        if c == 0:
            fig.paste(im, (x + (cell - im.width) // 2, y + label_h + (cell - im.height) // 2))
        else:
            fig.paste(im.resize((cell, cell), Image.LANCZOS), (x, y + label_h))
        draw.text((x, y + 4), f"{cols[c]}" + (f" ({ex}, {e.width}x{e.height})" if c == 0 else ", 512x512"), fill="black")
fig.save(dst, optimize=True)
print(dst, fig.size)
PY
