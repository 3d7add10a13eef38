#!/usr/bin/env bash
# The renderer's README figures (docs/images/render-*.png, viewer.png): contact sheets of the
# built-in head and of a user mesh (MediaPipe's canonical face from ../shared/data) under both
# lighting setups beside the raw maps; the web viewer in headless Chromium; the GLB in
# Blender's Cycles. The expression sequence is bench/expression_figure.sh's.
# Needs python3 with Pillow to scale and label the sheets.
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
cargo build --release -q --workspace --bins --examples --all-features
D=target/release/derma
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
mesh=../shared/data/canonical_face_model.obj
$D skin --size 2048 --seed 1 --out "$W/head" -q
$D render "$W/head" --sheet --size 1024 --out "$W/head-render" --device gpu -q
$D skin --size 2048 --seed 1 --mesh "$mesh" --landmarks mediapipe --out "$W/user" -q
$D render "$W/user" --mesh "$mesh" --sheet --size 1024 --out "$W/user-render" --device gpu -q
python3 - "$W" <<'PY'
import sys
from PIL import Image, ImageDraw
d = sys.argv[1]
def labelled(src, dst, labels, scale=0.5):
    im = Image.open(src).convert("RGB")
    im = im.resize((int(im.width * scale), int(im.height * scale)), Image.LANCZOS)
    draw = ImageDraw.Draw(im)
    for (x, y, text) in labels:
        box = draw.textbbox((x * scale + 8, y * scale + 6), text)
        draw.rectangle((box[0] - 4, box[1] - 3, box[2] + 4, box[3] + 3), fill=(12, 12, 14))
        draw.text((x * scale + 8, y * scale + 6), text, fill=(235, 235, 235))
    im.save(dst)
    print("wrote", dst, im.size)
P = 1024
tile = 2 * P // 3
maps = ["base colour", "normal", "roughness", "specular", "sss colour", "sss radius"]
labels = [(0, 0, "studio"), (0, P, "window")]
labels += [(3 * P + (i % 2) * tile, (i // 2) * tile, m) for i, m in enumerate(maps)]
labelled(f"{d}/head-render/sheet.png", "docs/images/render-head.png", labels)
labelled(f"{d}/user-render/sheet.png", "docs/images/render-user-mesh.png", labels)
PY
SHOT=docs/images/viewer.png bash scripts/viewer_test.sh
$D export glb "$W/head" --out "$W/head.glb" -q
RENDER="$W/blender.png" SAMPLES=64 SIZE=768 bash scripts/blender_import.sh "$W/head.glb" | grep -v "^Fra:"
cp "$W/blender.png" docs/images/render-blender.png
