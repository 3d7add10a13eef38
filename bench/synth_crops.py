"""The synthesis benches' exemplars, two grey and two colour: the forehead displacement crop at
128² and 256², the forehead albedo crop (256×128) and its left 128². No synthesis test reads the
albedo (only the photo pipeline's held-out test does). Provenance:
../shared/data/skin_exemplars.PROVENANCE.txt.
    python3 bench/synth_crops.py DATA OUT"""
import sys

from PIL import Image

data, out = sys.argv[1], sys.argv[2]
d = Image.open(f"{data}/skin_displacement_forehead_512.png")
d.crop((0, 0, 128, 128)).save(f"{out}/disp128.png")
d.crop((0, 0, 256, 256)).save(f"{out}/disp256.png")
a = Image.open(f"{data}/skin_albedo_forehead_256x128.png").convert("RGB")
a.save(f"{out}/albedo256x128.png")
a.crop((0, 0, 128, 128)).save(f"{out}/albedo128.png")
