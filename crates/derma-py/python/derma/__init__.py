"""derma: the appearance of digital humans, from biology.

The libraries of the ``derma`` command-line tool, called from Python: procedural skin texture
sets (:func:`skin`), the built-in head as arrays (:func:`head`), exemplar synthesis
(:func:`synth`), the hemoglobin rig (:class:`Rig`), photo bakes (:func:`photo_bake`) and
eye-region animation (:func:`eyes_animate`). Maps come back as numpy arrays that view derma's
own memory (no copy); work runs with the GIL released; ``progress`` takes a callable
``progress(stage: str, done: int, total: int)``; errors raise :class:`DermaError` with derma's
message. See docs/python.md in the repository.
"""

from __future__ import annotations

import json
import numbers
import os
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as np

# Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid or not set" when wgpu opens them
# without one (headless servers). Where it is unset, the package gives them a private
# directory of its own (0700, as the XDG specification asks); where it is set, nothing changes.
if not os.environ.get("XDG_RUNTIME_DIR"):
    os.environ["XDG_RUNTIME_DIR"] = __import__("tempfile").mkdtemp(prefix="derma-xdg-")

from . import _derma  # noqa: E402
from ._derma import DermaError, __version__  # noqa: E402

__all__ = [
    "DermaError",
    "Rig",
    "__version__",
    "eyes_animate",
    "head",
    "photo_bake",
    "skin",
    "synth",
]

PathLike = Union[str, "os.PathLike[str]"]
Progress = Callable[[str, int, int], Any]


def _path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def _arrays(d: Mapping[str, Any]) -> dict:
    """Wraps derma's buffers as numpy arrays (views, read-only) and keeps other values."""
    return {k: (np.asarray(v) if isinstance(v, _derma.Array) else v) for k, v in d.items()}


def skin(
    *,
    size: Optional[int] = None,
    seed: Optional[int] = None,
    preset: Optional[str] = None,
    ita_deg: Optional[float] = None,
    sex: Optional[str] = None,
    age: Optional[float] = None,
    mesh: Optional[PathLike] = None,
    head: Optional[PathLike] = None,
    fields: Optional[PathLike] = None,
    config: Optional[PathLike] = None,
    appearance: str = "table",
    threads: Optional[int] = None,
    device: str = "auto",
    out: Optional[PathLike] = None,
    glb: bool = False,
    progress: Optional[Progress] = None,
) -> dict:
    """Paints a procedural skin texture set (``derma skin``) and returns its maps.

    Arguments follow ``derma skin``: ``size`` texels (default the config's, 2048), ``seed``
    (default 1), the person — ``preset`` (very-light, light, intermediate, tan, brown, dark) or
    ``ita_deg``, ``sex`` ("male"/"female"), ``age`` in years — a ``mesh`` with UVs (OBJ, glTF,
    GLB) or a fitted ``head`` directory, painted ``fields``, a TOML ``config``, the
    ``appearance`` ("table" or "analytic"), ``threads`` and ``device`` ("auto", "cpu", "gpu").
    With ``out`` the whole set is also written there (and ``head.glb`` with ``glb=True``).

    Returns a dict of read-only numpy arrays, rows from the top of the texture (v = 1), in the
    encodings of the files: ``base_color`` (h, w, 3) uint8 sRGB, ``normal`` (h, w, 3) uint16
    (n·½+½, OpenGL +Y), ``roughness`` and ``specular`` (h, w) uint8 (specular = F0 / 0.08),
    ``sss_color`` (h, w, 3) uint8 sRGB and ``sss_radius`` (h, w, 3) uint16 (the table
    appearance only), ``bio`` (h, w, 13) float32 — every bio parameter per texel, channels
    named in ``info["bio_channels"]`` — and, as views into it, ``melanin`` and ``hemoglobin``
    (h, w) volume fractions and ``height_mm`` (h, w); and ``info``: size, seed, person,
    feature count, notes, files. No map is copied: each is a view of derma's own memory.
    The same arguments and seed give the same arrays, bit for bit, at any thread count.
    """
    request = dict(
        size=size,
        seed=seed,
        preset=preset,
        ita_deg=ita_deg,
        sex=sex,
        age=age,
        mesh=_path(mesh),
        head=_path(head),
        fields=_path(fields),
        config=_path(config),
        appearance=appearance,
        threads=threads,
        device=device,
    )
    d = _derma.skin(request, out=_path(out), glb=glb, progress=progress)
    maps = _arrays(d)
    # The bio samples are one (h, w, 13) array; the main planes are views into it.
    channel = {name: i for i, name in enumerate(maps["info"]["bio_channels"])}
    for key, name in [("melanin", "melanin"), ("hemoglobin", "blood"), ("height_mm", "height_mm")]:
        maps[key] = maps["bio"][:, :, channel[name]]
    return maps


def head(fitted: Optional[PathLike] = None) -> dict:
    """The built-in head (or a fitted one, ``derma head fit``'s directory) as arrays.

    ``vertices`` and ``normals`` (n, 3) float32 in mm, ``uvs`` (n, 2) float32 (v up),
    ``faces`` (m, 3) uint32, ``face_units``: {ARKit name: {"indices": (k,) uint32,
    "offsets": (k, 3) float32 mm}} (add ``w * offsets`` to ``vertices[indices]`` to pose),
    ``landmarks``: {name: (x, y, z) mm}.
    """
    d = _arrays(_derma.head(_path(fitted)))
    d["face_units"] = {name: _arrays(u) for name, u in d["face_units"].items()}
    return d


def synth(
    exemplar: np.ndarray,
    size: Union[int, Sequence[int]],
    *,
    seed: int = 1,
    tile: bool = False,
    patch: Optional[int] = None,
    passes: Optional[int] = None,
    settle: Optional[float] = None,
    search: str = "coherent",
    device: str = "auto",
    progress: Optional[Progress] = None,
) -> np.ndarray:
    """Grows a texture from an exemplar (``derma synth``; Shen et al.).

    ``exemplar``: (h, w) or (h, w, c) array of any real type (values as they are, e.g. height
    in mm or linear colour); ``size``: n or (width, height). Returns (height, width, c)
    float32 (or (height, width) for a 2-D exemplar); the same seed gives the same texture on
    CPU and GPU. ``settle``: the self-adaptive optimisation's factor (0 searches every window
    every pass); ``search``: ``"coherent"`` (k-coherence candidates) or ``"exhaustive"`` (every
    exemplar window), as ``derma synth --settle/--search``.
    """
    ex = np.asarray(exemplar)
    flat = ex.ndim == 2
    if flat:
        ex = ex[:, :, None]
    if ex.ndim != 3:
        raise DermaError(f"exemplar: shape {np.shape(exemplar)}: expected (h, w) or (h, w, c)")
    ex = np.ascontiguousarray(ex, dtype=np.float32)
    w, h = (size, size) if isinstance(size, numbers.Integral) else tuple(size)
    if not (int(w) > 0 and int(h) > 0):
        raise DermaError(f"size: {w}×{h}: expected positive whole numbers of texels")
    out = np.asarray(
        _derma.synth(
            ex.tobytes(),
            ex.shape[1],
            ex.shape[0],
            ex.shape[2],
            int(w),
            int(h),
            seed=seed,
            tile=tile,
            patch=patch,
            passes=passes,
            settle=settle,
            search=search,
            device=device,
            progress=progress,
        )
    )
    return out[:, :, 0] if flat else out


class Rig:
    """The skin appearance rig of Jimenez et al. 2010: hemoglobin by expression and emotion.

    Build one on a texture set with :meth:`build` (as ``derma rig build --set``) or load a rig
    directory with :meth:`load`; :meth:`evaluate` gives a frame's hemoglobin and colour.
    """

    def __init__(self, inner: Any) -> None:
        self._inner = inner

    @staticmethod
    def build(
        set_dir: PathLike,
        out: PathLike,
        *,
        radius: float,
        builtin: Optional[Sequence[str]] = None,
        targets: Optional[Mapping[str, PathLike]] = None,
        mask: Optional[PathLike] = None,
        basis_size: int = 256,
        sigma_floor: Optional[float] = None,
        progress: Optional[Progress] = None,
    ) -> "Rig":
        """Builds a rig on the set in ``set_dir`` with the built-in expression library entries
        ``builtin`` (default ["all"]) and target maps {name: file}; ``radius`` is the local
        statistics' disk radius in texels, ``basis_size`` the scale/bias textures' resolution
        (Jimenez et al. 2010 §6: 256; it must divide the map), ``sigma_floor`` the σ floor as a
        fraction of the neutral's RMS local σ (None: derma's default). Saves it into ``out``."""
        extra = {} if sigma_floor is None else {"sigma_floor": sigma_floor}
        return Rig(
            _derma.Rig.build(
                _path(set_dir),
                _path(out),
                radius=radius,
                builtin=None if builtin is None else list(builtin),
                targets=None if targets is None else {k: _path(v) for k, v in targets.items()},
                mask=_path(mask),
                basis_size=basis_size,
                progress=progress,
                **extra,
            )
        )

    @staticmethod
    def load(directory: PathLike) -> "Rig":
        """Loads a rig directory (``derma rig build``'s output)."""
        return Rig(_derma.Rig.load(_path(directory)))

    @property
    def targets(self) -> list:
        """The targets' names."""
        return list(self._inner.targets)

    @property
    def size(self) -> tuple:
        """(width, height) of its maps."""
        return tuple(self._inner.size)

    def evaluate(
        self,
        weights: Mapping[str, float],
        global_scale: Optional[float] = None,
        device: str = "cpu",
    ) -> dict:
        """One frame: {target: weight} (the neutral takes the rest, the sum at most 1); the
        global hemoglobin scale a factor, or None for each target's suggested one; ``device``
        "cpu", "gpu" or "auto". Returns {"hemoglobin": (h, w) float32, "color": (h, w, 3)
        float32 linear sRGB (when the rig has melanin or a set's skin)}. A neutral frame of a
        rig built on a set is the set's base colour."""
        return _arrays(self._inner.evaluate(dict(weights), global_scale, device))


def photo_bake(
    mesh: PathLike,
    cameras: PathLike,
    out: PathLike,
    *,
    size: int = 2048,
    delight: bool = True,
    progress: Optional[Progress] = None,
) -> dict:
    """Bakes calibrated photos onto a mesh's UVs (``derma photo bake``) into ``out``; returns
    the bake report."""
    return json.loads(
        _derma.photo_bake(
            _path(mesh), _path(cameras), _path(out), size=size, delight=delight, progress=progress
        )
    )


def eyes_animate(
    out: PathLike,
    *,
    seconds: float = 4.0,
    fps: float = 30.0,
    seed: int = 1,
    activity: str = "rest",
    render: int = 0,
    head: Optional[PathLike] = None,
    progress: Optional[Progress] = None,
) -> dict:
    """Animates the eye region (``derma eyes animate``: idle gaze, saccades, blinks at the
    ``activity``'s rate) into ``out`` — curves.json, curves.csv, head.glb, and rendered frames
    of ``render`` px; returns the report."""
    return json.loads(
        _derma.eyes_animate(
            _path(out),
            seconds=seconds,
            fps=fps,
            seed=seed,
            activity=activity,
            render=render,
            head=_path(head),
            progress=progress,
        )
    )
