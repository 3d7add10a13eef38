#!/usr/bin/env bash
# The README's photo figures:
#  docs/images/photo-pipeline.png — the synthetic set (five photos of the built-in face, each
#    with its own key light, shadows, sheen, exposure, white balance and vignetting), the 2048²
#    bake with the lighting kept and de-lit, the shading taken out of photo 2, and the hemoglobin
#    and melanin maps recovered from the albedo (--exposure auto);
#  docs/images/photo-iris-teeth.png — scikit-image's astronaut photo (NASA, public domain)
#    through the iris and teeth pipelines: the eye and smile crops, the eyeball texture and
#    its polar iris, the labelled and equalised teeth.
# Installs scikit-image, Pillow and numpy into a virtual environment under target/.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/peer-figure
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q scikit-image pillow numpy OpenEXR
fi
py="$venv/bin/python"
source bench/common.sh
$D photo synthetic --width 1600 --out "$W/set" -q
$D photo calibrate --points "$W/set/points.json" --out "$W/cameras.json" -q >/dev/null
$D photo unwrap --mesh "$W/set/face.obj" --out "$W/uv.obj" -q >/dev/null
$D photo bake --mesh "$W/uv.obj" --cameras "$W/cameras.json" --size 2048 --out "$W/bake" -q >/dev/null
$D photo bake --mesh "$W/uv.obj" --cameras "$W/cameras.json" --size 2048 --keep-lighting --out "$W/lit" -q >/dev/null
$D photo chromophores --texture "$W/bake/albedo.exr" --mask "$W/bake/mask.png" --exposure auto --out "$W/chromo" -q >/dev/null
# Astronaut crops: her right eye (image left) and the smile, upsampled ×4 (Lanczos).
"$py" - "$W" <<'PY'
import sys
from skimage import data
from PIL import Image
w = sys.argv[1]
a = Image.fromarray(data.astronaut())
a.crop((186, 86, 222, 114)).resize((144, 112), Image.LANCZOS).save(f"{w}/eye.png")
a.crop((198, 132, 252, 156)).resize((216, 96), Image.LANCZOS).save(f"{w}/smile.png")
PY
$D photo iris --photo "$W/eye.png" --size 512 --out "$W/iris"
$D photo teeth --photo "$W/smile.png" --size 512 --out "$W/teeth"
mkdir -p docs/images
"$py" - "$W" <<'PY'
import sys
import numpy as np, OpenEXR
from PIL import Image, ImageDraw
w = sys.argv[1]

def exr(path, chan):
    f = OpenEXR.File(path)
    return np.asarray(f.channels()[chan].pixels, dtype=np.float32)

def grey(a, lo, hi):
    return Image.fromarray((np.clip((a - lo) / (hi - lo), 0, 1) * 255).astype(np.uint8)).convert("RGB")

def label(im, text):
    d = ImageDraw.Draw(im)
    d.rectangle((0, 0, 8 + 6 * len(text), 14), fill=(0, 0, 0))
    d.text((4, 2), text, fill=(235, 235, 235))
    return im

photos = [label(Image.open(f"{w}/set/photo{i}.png").convert("RGB").resize((320, 240)), f"photo {i}") for i in range(5)]
S = 384
lit = label(Image.open(f"{w}/lit/texture.png").convert("RGB").resize((S, S)), "lighting kept")
tex = label(Image.open(f"{w}/bake/albedo.png").convert("RGB").resize((S, S)), "de-lit albedo 2048^2")
shade = Image.new("RGB", (S, S), (0, 0, 0))
shade.paste(Image.open(f"{w}/bake/shading_2.png").convert("RGB").resize((S, S * 3 // 4)), (0, S // 8))
shade = label(shade, "shading taken out of photo 2")
mask = np.asarray(Image.open(f"{w}/bake/mask.png").convert("L")) > 127
hb = exr(f"{w}/chromo/hemoglobin.exr", "hemoglobin")
me = exr(f"{w}/chromo/melanin.exr", "melanin")
hb_im = label(grey(np.where(mask, hb, 0), 0.0, 0.12).resize((S, S)), "hemoglobin 0-0.12")
me_im = label(grey(np.where(mask, me, 0), 0.0, 0.15).resize((S, S)), "melanin 0-0.15")
sheet = Image.new("RGB", (1920, 240 + S), (16, 16, 16))
for i, p in enumerate(photos):
    sheet.paste(p, (i * 384 + 32, 0))
for i, p in enumerate([lit, tex, shade, hb_im, me_im]):
    sheet.paste(p, (i * S, 240))
sheet.save("docs/images/photo-pipeline.png")

eye = label(Image.open(f"{w}/eye.png").convert("RGB").resize((288, 224)), "astronaut eye x4")
globe = Image.open(f"{w}/iris/eye.png").convert("RGB")
globe = label(globe.crop((128, 128, 384, 384)).resize((224, 224)), "eyeball texture (front)")
polar = label(Image.open(f"{w}/iris/iris_polar.png").convert("RGB").resize((96, 224)), "polar")
smile = label(Image.open(f"{w}/smile.png").convert("RGB").resize((432, 192)), "astronaut smile x4")
eq = label(Image.open(f"{w}/teeth/teeth_equalised.png").convert("RGB").resize((432, 192)), "labelled + equalised")
sheet = Image.new("RGB", (1100, 440), (16, 16, 16))
x = 0
for im in (eye, globe, polar):
    sheet.paste(im, (x, 0)); x += im.size[0] + 12
sheet.paste(smile, (0, 240)); sheet.paste(eq, (450, 240))
sheet.save("docs/images/photo-iris-teeth.png")
print("wrote docs/images/photo-pipeline.png, docs/images/photo-iris-teeth.png")
PY
