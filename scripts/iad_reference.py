#!/usr/bin/env python3
"""Adding-doubling reference values for derma's Monte Carlo slab tests.

Computes total reflectance (specular included) and total transmittance of layered slabs under a
normally incident beam with iadpython (Prahl's adding-doubling, installed from PyPI:
`pip install iadpython scipy`), and writes them to
crates/derma-optics/tests/data/iad_cases.json, which the Rust tests read.

  python3 scripts/iad_reference.py           # regenerate the JSON
  python3 scripts/iad_reference.py --check   # recompute and compare with the committed JSON

Layers are stacked with iad.add_layers on matrices from iad.simple_layer_matrices, then the
boundaries with the media above and below are added explicitly (passing arrays of layers to
iad.Sample solves a different problem). All layers of a case share one refractive index, as the
adding-doubling quadrature requires. The harness is checked first on one layer against
Sample.rt() and against the published case of SKIN-OPTICS-REFERENCES (R 0.2605, T 0.4613).
"""
import json
import os
import sys

import iadpython as iad

QUAD = 16
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "crates", "derma-optics", "tests", "data", "iad_cases.json")

# (name, [(d_mm, mua_per_cm, mus_per_cm, g)], n, n_above, n_below)
CASES = [
    ("1 layer albedo 0.5 g 0 matched", [(0.5, 10.0, 10.0, 0.0)], 1.0, 1.0, 1.0),
    ("1 layer albedo 0.9 g 0.5 matched", [(0.5, 10.0, 90.0, 0.5)], 1.0, 1.0, 1.0),
    ("1 layer albedo 0.99 g 0.9 n 1.4 in air", [(1.0, 1.0, 100.0, 0.9)], 1.4, 1.0, 1.0),
    ("1 layer albedo 0.999 g 0.8 n 1.33 in air", [(0.5, 0.2, 200.0, 0.8)], 1.33, 1.0, 1.0),
    ("1 layer albedo 0.7 g 0.3 n 1.5 in air", [(0.3, 15.0, 35.0, 0.3)], 1.5, 1.0, 1.0),
    ("1 layer albedo 0.95 g 0.75 n 1.4 glass above and below", [(0.4, 5.0, 95.0, 0.75)], 1.4, 1.5, 1.5),
    ("1 layer albedo 0.8 g 0.9 n 1.37 air above, glass below", [(1.0, 5.0, 20.0, 0.9)], 1.37, 1.0, 1.5),
    ("2 layers n 1.4 in air (SKIN-OPTICS-REFERENCES)", [(0.1, 10.0, 400.0, 0.85), (1.0, 1.0, 200.0, 0.8)], 1.4, 1.0, 1.0),
    ("2 layers reversed n 1.4 in air", [(1.0, 1.0, 200.0, 0.8), (0.1, 10.0, 400.0, 0.85)], 1.4, 1.0, 1.0),
    ("2 layers albedo 0.5 / 0.99 g 0 / 0.9 matched", [(0.2, 20.0, 20.0, 0.0), (0.5, 1.0, 99.0, 0.9)], 1.0, 1.0, 1.0),
    ("2 layers n 1.5 in air", [(0.2, 3.0, 60.0, 0.6), (0.3, 8.0, 30.0, 0.2)], 1.5, 1.0, 1.0),
    ("3 layers n 1.4 in air", [(0.05, 20.0, 300.0, 0.8), (0.2, 2.0, 150.0, 0.85), (0.5, 0.5, 100.0, 0.9)], 1.4, 1.0, 1.0),
    ("3 layers matched", [(0.1, 5.0, 50.0, 0.0), (0.1, 30.0, 30.0, 0.5), (0.3, 0.5, 49.5, 0.7)], 1.0, 1.0, 1.0),
    ("3 layers n 1.33 glass above", [(0.1, 2.0, 100.0, 0.9), (0.2, 10.0, 90.0, 0.7), (0.2, 1.0, 60.0, 0.5)], 1.33, 1.5, 1.0),
]


def layer_sample(d_mm, mua, mus, g, n, n_above, n_below):
    mut = mua + mus
    s = iad.Sample(a=mus / mut, b=mut * d_mm / 10.0, g=g, n=n, n_above=n_above,
                   n_below=n_below, quad_pts=QUAD)
    s.update_quadrature()
    return s


def stack_rt(layers, n, n_above, n_below):
    samples = [layer_sample(*l, n, n_above, n_below) for l in layers]
    s0 = samples[0]
    R, T = iad.simple_layer_matrices(s0)
    R12, R21, T12, T21 = R, R, T, T
    for s in samples[1:]:
        Rb, Tb = iad.simple_layer_matrices(s)
        R12, R21, T12, T21 = iad.add_layers(s0, R12, R21, T12, T21, Rb, Rb, Tb, Tb)
    if n == 1.0 and n_above == 1.0 and n_below == 1.0:
        ur1, ut1, _, _ = s0.UX1_and_UXU(R12, T12)
        return float(ur1), float(ut1)
    R01, R10, T01, T10 = iad.boundary_layer(s0, top=True)
    R02, R20, T02, T20 = iad.add_slide_above(s0, R01, R10, T01, T10, R12, R21, T12, T21)
    R23, R32, T23, T32 = iad.boundary_layer(s0, top=False)
    R03, R30, T03, T30 = iad.add_slide_below(s0, R02, R20, T02, T20, R23, R32, T23, T32)
    ur1, ut1, _, _ = s0.UX1_and_UXU(R03, T03)
    return float(ur1), float(ut1)


def check_harness():
    r, t = stack_rt([(1.0, 1.0, 100.0, 0.9)], 1.4, 1.0, 1.0)
    s = layer_sample(1.0, 1.0, 100.0, 0.9, 1.4, 1.0, 1.0)
    r2, t2, _, _ = s.rt()
    assert abs(r - r2) < 1e-9 and abs(t - t2) < 1e-9, (r, t, r2, t2)
    assert abs(r - 0.2605) < 5e-4 and abs(t - 0.4613) < 5e-4, (r, t)
    # Splitting a layer in two must not change anything.
    r3, t3 = stack_rt([(0.5, 1.0, 100.0, 0.9), (0.5, 1.0, 100.0, 0.9)], 1.4, 1.0, 1.0)
    assert abs(r - r3) < 1e-6 and abs(t - t3) < 1e-6, (r, t, r3, t3)


def compute():
    check_harness()
    out = []
    for name, layers, n, na, nb in CASES:
        r, t = stack_rt(layers, n, na, nb)
        out.append({
            "name": name,
            "layers": [{"d_mm": d, "mua_per_cm": a, "mus_per_cm": s, "g": g, "n": n}
                       for d, a, s, g in layers],
            "n_above": na,
            "n_below": nb,
            "r_total": round(r, 6),
            "t_total": round(t, 6),
        })
    return {"source": f"iadpython {iad.__version__}, {QUAD} quadrature points, scripts/iad_reference.py",
            "cases": out}


def main():
    data = compute()
    if "--check" in sys.argv:
        with open(OUT) as f:
            old = json.load(f)
        bad = [(a["name"], a["r_total"], b["r_total"], a["t_total"], b["t_total"])
               for a, b in zip(old["cases"], data["cases"])
               if abs(a["r_total"] - b["r_total"]) > 2e-6 or abs(a["t_total"] - b["t_total"]) > 2e-6]
        if bad or len(old["cases"]) != len(data["cases"]):
            print("committed adding-doubling references differ from iadpython:", bad)
            sys.exit(1)
        print(f"{len(data['cases'])} adding-doubling references agree with iadpython {iad.__version__}")
        return
    with open(OUT, "w") as f:
        json.dump(data, f, indent=1)
        f.write("\n")
    for c in data["cases"]:
        print(f"{c['name']:<58} R {c['r_total']:.5f}  T {c['t_total']:.5f}")


if __name__ == "__main__":
    main()
