"""Makes a precompute table shaped like the optics' default grid (4^6 = 4096 nodes) from the
entries of a smaller precompute table, repeated, so that `derma match fit` can be timed on the
default grid's size without its ~6 h precompute. Fit time depends on the number of entries and
the BRDF/profile bins, not on which bio values the entries came from; the residuals of such a
table mean nothing.

Usage: python3 bench/tiled_default_grid.py SMALL.dtab OUT.dtab
"""
import json
import struct
import sys
import zlib

src, out = sys.argv[1], sys.argv[2]
raw = open(src, "rb").read()
assert raw[:4] == b"DTAB", f"{src}: not a .dtab"
version, hlen = struct.unpack_from("<II", raw, 4)
header = json.loads(raw[12:12 + hlen])
payload = raw[12 + hlen:-4]
stride = sum(v["len"] for v in header["values"])
nodes = len(payload) // (4 * stride)
row = 4 * stride
# The optics' DEFAULT_GRID axes (crates/derma-optics/src/precompute.rs).
axes = {
    "melanin": [0.002, 0.05, 0.2, 0.5],
    "pheomelanin": [0.0, 0.3, 0.6, 1.0],
    "blood": [0.002, 0.02, 0.08, 0.2],
    "oxygenation": [0.5, 0.7, 0.85, 1.0],
    "stratum_corneum_um": [5.0, 15.0, 30.0, 50.0],
    "epidermis_um": [20.0, 60.0, 120.0, 200.0],
}
header["axes"] = [{"name": n, "values": v} for n, v in axes.items()]
header["meta"]["tiled_from"] = src
total = 4 ** 6
data = b"".join(payload[(i % nodes) * row:(i % nodes + 1) * row] for i in range(total))
h = json.dumps(header).encode()
body = b"DTAB" + struct.pack("<II", version, len(h)) + h + data
open(out, "wb").write(body + struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF))
print(f"{out}: {total} nodes tiled from {nodes}")
