#!/usr/bin/env bash
# Faces from photographs against the peers (BENCHMARKS.md), same machine, same run:
#  1. Parameterisation of the built-in face disc (67 494 triangles, a disc closed at the eyes and
#     mouth): derma photo unwrap (view-independent and with §3.1's view weight) against libigl's
#     harmonic, LSCM, ARAP and SLIM (symmetric Dirichlet) from PyPI; every layout's L2 stretch
#     (Sander et al. 2001, normalised) from one Python implementation.
#  2. Resampling + blending a 4096² (and 2048²) texture from five 2400×1800 photos: derma photo
#     bake's own stage timings, and OpenCV's detail::MultiBandBlender (PyPI) blending five
#     images of the same size with the same masks.
#  3. The synthetic ground truth (cameras, PSNR, seams, chromophores) as the tests score it.
#   bash bench/photo.sh
# Needs python3 with venv (libigl, opencv-python-headless, numpy, pillow are installed into a
# virtual environment under target/peer-photo, never into the product).
set -euo pipefail
cd "$(dirname "$0")/.."
out=bench/out/photo
mkdir -p "$out"
venv=target/peer-photo
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q libigl==2.6.1 opencv-python-headless numpy pillow scipy
fi
py="$venv/bin/python"
cargo build --release -q -p derma
D=target/release/derma
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%F)"
echo "peers: $("$py" -c 'import igl, cv2; print("libigl", igl.__version__ if hasattr(igl, "__version__") else "?", "/ OpenCV", cv2.__version__)')"

# The synthetic set: five photos of the built-in face (2400×1800).
rm -rf "$out/set" "$out/uv_plain.obj" "$out/uv_view.obj" "$out/cameras.json" "$out/bake2048" "$out/bake4096"
$D photo synthetic --width 2400 --out "$out/set" -q
$D photo calibrate --points "$out/set/points.json" --out "$out/cameras.json"

# 1. Parameterisation.
t() { local s e; s=$(date +%s.%N); "$@" >"$out/last.txt"; e=$(date +%s.%N); echo "$e - $s" | bc; }
tp=$(t $D photo unwrap --mesh "$out/set/face.obj" --view none --out "$out/uv_plain.obj" -q)
echo "derma unwrap (view-independent): ${tp}s — $(cat "$out/last.txt")"
tv=$(t $D photo unwrap --mesh "$out/set/face.obj" --out "$out/uv_view.obj" -q)
echo "derma unwrap (view weight k = 1.2): ${tv}s — $(cat "$out/last.txt")"

"$py" - "$out" "$tp" <<'PY'
import sys, time, json
import numpy as np, igl
out, t_derma = sys.argv[1], float(sys.argv[2])

sys.path.insert(0, "bench")
from objfile import read_obj

def load_obj(path):
    # Triangles by position index (derma's OBJs index positions and UVs alike).
    V, VT, F = read_obj(path)
    return V, (VT if len(VT) else None), np.array([[c[0] for c in f[:3]] for f in F], dtype=np.int64)

def l2_stretch(V, F, UV):
    # Sander et al. 2001 §3: per triangle, S_s, S_t = ∂q/∂s, ∂q/∂t; L2 = sqrt((a + c)/2) with
    # a = S_s·S_s, c = S_t·S_t; mesh L2 = sqrt(Σ L2² A3 / Σ A3), normalised by sqrt(ΣA2/ΣA3).
    q1, q2, q3 = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    s1, s2, s3 = UV[F[:, 0]], UV[F[:, 1]], UV[F[:, 2]]
    A2 = ((s2[:, 0] - s1[:, 0]) * (s3[:, 1] - s1[:, 1]) - (s3[:, 0] - s1[:, 0]) * (s2[:, 1] - s1[:, 1])) / 2
    flipped = int((A2 <= 0).sum())
    Ss = (q1 * (s2[:, 1] - s3[:, 1])[:, None] + q2 * (s3[:, 1] - s1[:, 1])[:, None] + q3 * (s1[:, 1] - s2[:, 1])[:, None]) / (2 * A2)[:, None]
    St = (q1 * (s3[:, 0] - s2[:, 0])[:, None] + q2 * (s1[:, 0] - s3[:, 0])[:, None] + q3 * (s2[:, 0] - s1[:, 0])[:, None]) / (2 * A2)[:, None]
    a, c = (Ss * Ss).sum(1), (St * St).sum(1)
    A3 = np.linalg.norm(np.cross(q2 - q1, q3 - q1), axis=1) / 2
    ok = A2 > 0
    L2 = np.sqrt(((a + c)[ok] / 2 * A3[ok]).sum() / A3[ok].sum())
    return float(L2 * np.sqrt(np.abs(A2).sum() / A3.sum())), flipped

V, _, F = load_obj(f"{out}/set/face.obj")
rows = []
Vd, UVd, Fd = load_obj(f"{out}/uv_plain.obj")
s, fl = l2_stretch(Vd, Fd, UVd)
rows.append(("derma unwrap", t_derma, s, fl))
t0 = time.time()
bnd = igl.boundary_loop(F)
bnd_uv = igl.map_vertices_to_circle(np.asfortranarray(V), bnd.astype(np.int32))
uv_h = igl.harmonic(V, F, bnd, np.ascontiguousarray(bnd_uv), 1)
t_h = time.time() - t0
rows.append(("libigl harmonic", t_h, *l2_stretch(V, F, uv_h)))
t0 = time.time()
far = bnd[len(bnd) // 2]
uv_l, _ = igl.lscm(V, F, np.array([bnd[0], far]), np.array([[0.0, 0.0], [1.0, 0.0]]))
rows.append(("libigl LSCM", time.time() - t0, *l2_stretch(V, F, uv_l)))
t0 = time.time()
data = igl.ARAPData()
data.max_iter = 100
igl.arap_precomputation(V, F, 2, np.zeros(0, dtype=np.int32), data)
uv_a = igl.arap_solve(np.zeros((0, 2)), data, uv_h)
rows.append(("libigl ARAP (100 it.)", time.time() - t0 + t_h, *l2_stretch(V, F, uv_a)))
# SLIM (symmetric Dirichlet) needs a flip-free start: Tutte's embedding with uniform weights
# (the cotangent-weighted harmonic map above flips triangles of the closed eye and mouth fans).
import scipy.sparse as sp, scipy.sparse.linalg as spl
t0 = time.time()
n = len(V)
I = np.concatenate([F[:, 0], F[:, 1], F[:, 2], F[:, 1], F[:, 2], F[:, 0]])
J = np.concatenate([F[:, 1], F[:, 2], F[:, 0], F[:, 0], F[:, 1], F[:, 2]])
A = sp.coo_matrix((np.ones(len(I)), (I, J)), shape=(n, n)).tocsr()
A.data[:] = 1.0
L = (sp.diags(np.asarray(A.sum(1)).ravel()) - A).tocsr()
inner = np.setdiff1d(np.arange(n), bnd)
uv_t = np.zeros((n, 2))
uv_t[bnd] = bnd_uv
uv_t[inner] = spl.spsolve(L[inner][:, inner].tocsc(), -(L[inner][:, bnd] @ bnd_uv))
t_t = time.time() - t0
rows.append(("Tutte (uniform, scipy)", t_t, *l2_stretch(V, F, uv_t)))
t0 = time.time()
slim = igl.slim_precompute(np.asfortranarray(V), np.asfortranarray(F.astype(np.int32)), np.asfortranarray(uv_t),
                           igl.MappingEnergyType.SYMMETRIC_DIRICHLET, np.zeros(0, dtype=np.int32), np.zeros((0, 2), order="F"))
best = None
for it in range(1, 31):
    uv_s = igl.slim_solve(slim, 1)
    st, fl = l2_stretch(V, F, uv_s)
    if it in (5, 10, 20, 30):
        rows.append((f"libigl SLIM ({it} it.)", time.time() - t0 + t_t, st, fl))
for name, t, s, fl in rows:
    print(f"{name:<24} {t:7.2f} s  L2 stretch {s:.4f}  flipped {fl}")
json.dump([dict(tool=n, seconds=t, l2=s, flipped=fl) for n, t, s, fl in rows], open(f"{out}/unwrap.json", "w"), indent=1)
PY

# 2. Resampling + blending: three runs per size (this machine's timings vary by ±25 %), each
# stage's median and the best total.
for size in 2048 4096; do
  for run in 1 2 3; do
    rm -rf "$out/bake$size"
    $D photo bake --mesh "$out/uv_view.obj" --cameras "$out/cameras.json" --size $size --out "$out/bake$size" -q >/dev/null
    cp "$out/bake$size/bake.json" "$out/bake${size}_run$run.json"
  done
  "$py" - "$out" $size <<'PY'
import json, sys, statistics
out, size = sys.argv[1], sys.argv[2]
runs = [json.load(open(f"{out}/bake{size}_run{r}.json"))["seconds"] for r in (1, 2, 3)]
med = [statistics.median(r[k] for r in runs) for k in range(3)]
totals = sorted(sum(r) for r in runs)
print(f"derma bake {size}²: bind + gains {med[0]:.2f} s, resample {med[1]:.2f} s, splines {med[2]:.2f} s (medians); "
      f"total median {totals[1]:.2f} s, best {totals[0]:.2f} s, worst {totals[2]:.2f} s")
PY
done
"$py" - "$out" <<'PY'
import sys, time
import numpy as np, cv2
from PIL import Image
out = sys.argv[1]
for size in (2048, 4096):
    src = np.asarray(Image.open(f"{out}/bake{size}/source.png").convert("L"))
    tex = np.asarray(Image.open(f"{out}/bake{size}/albedo.png").convert("RGB"))
    imgs, masks = [], []
    levels = sorted(set(np.unique(src)) - {0})
    for k, lv in enumerate(levels[:5]):
        imgs.append(np.clip(tex.astype(np.int16) + 3 * k, 0, 255).astype(np.int16))
        masks.append(((src == lv) * 255).astype(np.uint8))
    while len(imgs) < 5:
        imgs.append(tex.astype(np.int16)); masks.append(np.zeros_like(src, dtype=np.uint8))
    bands = int(np.log2(size)) - 3
    best = 1e9
    for _ in range(3):
        t0 = time.time()
        b = cv2.detail_MultiBandBlender(try_gpu=0, num_bands=bands)
        b.prepare((0, 0, size, size))
        for im, m in zip(imgs, masks):
            b.feed(im, m, (0, 0))
        res, _ = b.blend(None, None)
        best = min(best, time.time() - t0)
    print(f"OpenCV MultiBandBlender {size}² ({bands} bands, 5 images): {best:.2f} s (best of 3)")
PY

# 3. Ground truth as the tests score it.
cargo test --release -q -p derma-photo --test suite ground_truth:: -- --nocapture 2>&1 | grep -E "plain|gain|melanin" || true
