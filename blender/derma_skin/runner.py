"""Running derma's main job from Blender: through the `derma` Python package when Blender's
Python can import it, else through the `derma` command line (the add-on's preference, or
`derma` on PATH). Both write the same texture set (docs/skin.md)."""

import json
import os
import shutil
import subprocess


# Windows' reserved device names: no folder may be called so, whatever its extension.
_RESERVED = {"con", "prn", "aux", "nul"} | {f"{d}{i}" for d in ("com", "lpt") for i in range(1, 10)}


def safe_name(name, fallback="object"):
    """`name` as a folder name that is safe on every file system: ASCII letters, digits, '.',
    '-' and '_' kept, every other character '_'; no leading '.' or '-', no trailing '.'; at
    most 64 characters; a Windows device name (CON, NUL, COM1…) prefixed with '_'; `fallback`
    when nothing is left."""
    s = "".join(c if c.isascii() and (c.isalnum() or c in "._-") else "_" for c in name or "")
    s = s.lstrip(".-")[:64].rstrip(".")
    if not s:
        s = fallback
    if s.split(".")[0].lower() in _RESERVED:
        s = "_" + s
    return s


def _key(path):
    """A path as compared for a clash: absolute, normalised and case-folded (two names that
    differ in case alone are one folder on macOS and Windows)."""
    return os.path.normcase(os.path.normpath(os.path.abspath(path))).lower()


def texture_dir(root, name, own=None, claimed=()):
    """The folder under `root` for the texture set of the object called `name`, never another
    object's: `own` (the folder an earlier paint of this object recorded) when it lies in `root`
    and no other object claims it; else root/safe_name(name), with -2, -3, … appended while
    that folder is claimed by another object (`claimed`: the folders other objects recorded)
    or already holds files (a set painted before, for an object since deleted or in another
    .blend)."""
    root = os.path.abspath(root)
    taken = {_key(p) for p in claimed}
    if own and _key(os.path.dirname(os.path.normpath(own))) == _key(root) and _key(own) not in taken:
        return os.path.normpath(own)
    base = safe_name(name)
    n = 1
    while True:
        d = os.path.join(root, base if n == 1 else f"{base}-{n}")
        used = os.path.isdir(d) and any(os.scandir(d))
        if _key(d) not in taken and not used and not (os.path.exists(d) and not os.path.isdir(d)):
            return d
        n += 1


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
