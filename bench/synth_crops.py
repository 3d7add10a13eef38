"""The synthesis benches' exemplars, two grey and two colour: the forehead displacement crop at
128² and 256², the forehead albedo crop (256×128) and its left 128². No synthesis test reads the
albedo (only the photo pipeline's held-out test does). Provenance:
../shared/data/skin_exemplars.PROVENANCE.txt.

With CORPUS (scripts/corpus.py's directory) holding Lee Perry-Smith's photographed albedo
(Map-COL.jpg, CC BY 3.0, Infinite-Realities via three.js; provenance in corpus.py), two more
colour crops that no synthesis test or tuning has seen — the same photograph as the albedo crop
above (its forehead, x 436..692, y 100..228), another part of it: lps256 (neck and upper chest
with two moles, 256² at (130, 590)) and lps128 (its top-left 128²); lpsr128, 128² of the
other side of the neck at (800, 660), cut after every choice of issue 64's second stop was made
and run once. With Jon Cole's scan texture
there too (jon.jpg, MIT, a camera-projected atlas with its light baked in; provenance in
corpus.py): jon128, 128² of his forehead at (480, 660), a second photograph held out from every
choice of the synthesis' constants.
    python3 bench/synth_crops.py DATA OUT [CORPUS]"""
import os
import sys

from PIL import Image

data, out = sys.argv[1], sys.argv[2]
corpus = sys.argv[3] if len(sys.argv) > 3 else None
d = Image.open(f"{data}/skin_displacement_forehead_512.png")
d.crop((0, 0, 128, 128)).save(f"{out}/disp128.png")
d.crop((0, 0, 256, 256)).save(f"{out}/disp256.png")
a = Image.open(f"{data}/skin_albedo_forehead_256x128.png").convert("RGB")
a.save(f"{out}/albedo256x128.png")
a.crop((0, 0, 128, 128)).save(f"{out}/albedo128.png")
if corpus and os.path.exists(f"{corpus}/Map-COL.jpg"):
    lps = Image.open(f"{corpus}/Map-COL.jpg").convert("RGB")
    lps.crop((130, 590, 258, 718)).save(f"{out}/lps128.png")
    lps.crop((130, 590, 386, 846)).save(f"{out}/lps256.png")
    lps.crop((800, 660, 928, 788)).save(f"{out}/lpsr128.png")
if corpus and os.path.exists(f"{corpus}/jon.jpg"):
    jon = Image.open(f"{corpus}/jon.jpg").convert("RGB")
    jon.crop((480, 660, 608, 788)).save(f"{out}/jon128.png")
