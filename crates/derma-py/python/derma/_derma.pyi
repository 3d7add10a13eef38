"""Type stubs of derma's extension module (the Rust side of the `derma` package). Use the
wrappers in `derma` (they turn buffers into numpy arrays); these describe what they call."""

from typing import Any, Callable, Optional, Sequence, final

__all__ = [
    "DermaError",
    "__version__",
    "Array",
    "Rig",
    "skin",
    "head",
    "synth",
    "photo_bake",
    "eyes_animate",
]
__version__: str

class DermaError(Exception):
    """An error of derma's libraries, naming the file, key or value and what was expected."""

@final
class Array:
    """A read-only buffer owned by derma; `numpy.asarray` views it without a copy."""

    @property
    def __array_interface__(self) -> dict[str, Any]: ...
    @property
    def shape(self) -> list[int]: ...

_Progress = Optional[Callable[[str, int, int], Any]]

# `request`: every keyword of `derma.skin` but out, glb and progress (None: the config's value).
def skin(
    request: dict[str, Any],
    *,
    out: Optional[str] = ...,
    glb: bool = ...,
    progress: _Progress = ...,
) -> dict[str, Any]: ...
def head(fitted: Optional[str] = ...) -> dict[str, Any]: ...
def synth(
    exemplar: bytes,
    ex_width: int,
    ex_height: int,
    channels: int,
    width: int,
    height: int,
    *,
    seed: int = ...,
    tile: bool = ...,
    patch: Optional[int] = ...,
    passes: Optional[int] = ...,
    settle: Optional[float] = ...,
    search: str = ...,
    device: str = ...,
    progress: _Progress = ...,
) -> Array: ...
def photo_bake(
    mesh: str,
    cameras: str,
    out: str,
    *,
    size: int = ...,
    delight: bool = ...,
    progress: _Progress = ...,
) -> str: ...
def eyes_animate(
    out: str,
    *,
    seconds: float = ...,
    fps: float = ...,
    seed: int = ...,
    activity: str = ...,
    render: int = ...,
    head: Optional[str] = ...,
    progress: _Progress = ...,
) -> str: ...

@final
class Rig:
    @staticmethod
    def build(
        set_dir: str,
        out: str,
        *,
        radius: float,
        builtin: Optional[Sequence[str]] = ...,
        targets: Optional[dict[str, str]] = ...,
        mask: Optional[str] = ...,
        basis_size: int = ...,
        sigma_floor: float = ...,
        progress: _Progress = ...,
    ) -> Rig: ...
    @staticmethod
    def load(dir: str) -> Rig: ...
    @property
    def targets(self) -> list[str]: ...
    @property
    def size(self) -> tuple[int, int]: ...
    def evaluate(
        self,
        weights: dict[str, float],
        global_scale: Optional[float] = ...,
        device: str = ...,
    ) -> dict[str, Array]: ...
