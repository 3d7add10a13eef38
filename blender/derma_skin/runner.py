"""Running derma's main job from Blender: through the `derma` Python package when Blender's
Python can import it, else through the `derma` command line (the add-on's preference, or
`derma` on PATH). Both write the same texture set (docs/skin.md)."""

import json
import os
import shutil
import subprocess


def person_args(preset, sex, age, size, seed):
    """`derma skin`'s flags for the panel's settings (the preset "config" keeps the config's)."""
    args = ["--size", str(size), "--seed", str(seed), "--sex", sex, "--age", f"{age:g}"]
    if preset != "config":
        args += ["--preset", preset]
    return args


def run_skin(executable, out_dir, preset, sex, age, size, seed, mesh=None, glb=False):
    """Paints a set into `out_dir` (with head.glb when `glb`), on `mesh` when given (an OBJ
    the add-on exported), else on derma's built-in head. Returns report.json as a dict."""
    os.makedirs(out_dir, exist_ok=True)
    try:
        import derma  # the Python package (crates/derma-py), when installed for this Python

        derma.skin(
            size=size,
            seed=seed,
            preset=None if preset == "config" else preset,
            sex=sex,
            age=age,
            mesh=mesh,
            out=out_dir,
            glb=glb,
        )
    except ImportError:
        exe = shutil.which(executable) or executable
        if not os.path.isfile(exe):
            raise RuntimeError(
                f"derma not found: '{executable}' is not a file or on PATH, and the derma "
                "Python package is not importable; set the add-on's derma path"
            )
        cmd = [exe, "skin", "--out", out_dir, "--quiet"] + person_args(preset, sex, age, size, seed)
        if mesh:
            cmd += ["--mesh", mesh]
        if glb:
            cmd.append("--glb")
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"derma skin failed: {done.stderr.strip() or done.stdout.strip()}")
    with open(os.path.join(out_dir, "report.json"), encoding="utf-8") as f:
        return json.load(f)


def mm_per_unit(report):
    """Millimetres per unit of the mesh derma painted, as derma read it (report.json's
    inputs.mesh.mm_per_unit: its length unit, or the scale that fitted it to a head); the
    built-in head's GLB is in metres."""
    mesh = (report.get("inputs") or {}).get("mesh") or {}
    return float(mesh.get("mm_per_unit") or 1000.0)
