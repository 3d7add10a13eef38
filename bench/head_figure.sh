#!/usr/bin/env bash
# The README's fitting figure (docs/images/head-fit.png): a stand-in for a user's head (the
# ground-truth scan of crates/derma-head/tests/support/truth.rs, seed 2: the built-in head's skin
# retriangulated, warped by up to 10 mm, turned and written in cm, with the template's UVs) painted by `derma skin --mesh
# --head` through its fit; the fitted head with its own skin; the user mesh smiling through the
# carried face units; and its eyes animated by `derma eyes animate --head --mesh` (three frames). Needs python3 with Pillow.
set -euo pipefail
cd "$(dirname "$0")/.."
source bench/common.sh
cargo build --release -q -p derma-head --example fit_truth
WRITE="$W/scan.obj" target/release/examples/fit_truth 2 10 > /dev/null
$D head fit --mesh "$W/scan.obj" --out "$W/fitted" -q
$D skin --mesh "$W/scan.obj" --head "$W/fitted" --size 1024 --seed 1 --out "$W/scan_skin" -q
$D skin --head "$W/fitted" --size 1024 --seed 1 --out "$W/fit_skin" -q
common=(--size 512 --lighting studio --yaw 20 -q)
$D render "$W/scan_skin" --mesh "$W/scan.obj" --head "$W/fitted" --out "$W/r_scan" "${common[@]}" > /dev/null
$D render "$W/fit_skin" --head "$W/fitted" --out "$W/r_fit" "${common[@]}" > /dev/null
$D render "$W/scan_skin" --mesh "$W/scan.obj" --head "$W/fitted" --out "$W/r_smile" "${common[@]}" \
  --pose mouthSmileLeft=1,mouthSmileRight=1,browInnerUp=0.6 > /dev/null
$D eyes animate --head "$W/fitted" --mesh "$W/scan.obj" --seconds 4 --fps 15 --seed 3 --render 512 \
  --out "$W/eyes" -q > /dev/null
python3 - "$W" <<'PY'
import sys, glob
from PIL import Image, ImageDraw
d = sys.argv[1]
panels = [(f"{d}/r_scan/studio.png", "a user mesh (its own triangulation), painted through the fit"),
          (f"{d}/r_fit/studio.png", "the fitted head, its own skin"),
          (f"{d}/r_smile/studio.png", "the user mesh smiling (face units carried over)")]
ims = [(Image.open(p).convert("RGB"), t) for p, t in panels]
import csv
frames = sorted(glob.glob(f"{d}/eyes/frames/*.png"))
# An open frame, the most closed one (a blink) and the last.
closure = [float(r["blink_closure"]) for r in csv.DictReader(open(f"{d}/eyes/curves.csv"))]
shut = max(range(len(closure)), key=lambda i: closure[i])
eyes = [Image.open(frames[i]).convert("RGB") for i in (0, shut, len(frames) - 1)]
w, h = ims[0][0].size
ew, eh = eyes[0].size
eh2 = int(eh * (w * 3 / 3) / ew)
sheet = Image.new("RGB", (3 * w, h + 18 + eh2 + 18), (12, 12, 12))
for i, (im, t) in enumerate(ims):
    sheet.paste(im, (i * w, 18))
    ImageDraw.Draw(sheet).text((i * w + 8, 3), t, fill=(230, 230, 230))
for i, im in enumerate(eyes):
    sheet.paste(im.resize((w, eh2), Image.LANCZOS), (i * w, h + 36))
ImageDraw.Draw(sheet).text((8, h + 21), "the user mesh's eyes animated (derma eyes animate --head --mesh): open, the deepest blink, the last frame", fill=(230, 230, 230))
sheet.save("docs/images/head-fit.png", optimize=True)
print("wrote docs/images/head-fit.png", sheet.size)
PY
