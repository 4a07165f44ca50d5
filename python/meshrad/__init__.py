"""meshrad: meshless hierarchical radiosity (Zollhöfer & Stamminger 2011) on the CPU and on
Vulkan compute, from Python.

    import meshrad
    scene = meshrad.load("scenes/cornell_box.toml")        # or meshrad.Scene.embedded()
    sol = meshrad.solve(scene, backend="cpu", rays=256)    # any [solver] key
    img = sol.images()["total"]                            # (H, W, 3) float32, linear
    vals = sol.probe(points)                               # points: (N, 6) position, normal
    scene.edit(lights={"spot": {"intensity": [1.5e5] * 3}})
    sol = meshrad.solve(scene)                             # re-solves, hierarchy kept

The Rust library is the one implementation: a solve on the CPU backend gives the bytes of
`meshrad solve` (of `meshrad session` once the scene was edited). Solves release the GIL.
"""

import sys
import warnings

from ._errors import DeviceError, Error, FileError, ResourceError
from . import _meshrad
from ._meshrad import Scene, Solution, __version__, devices, load

__all__ = [
    "Scene",
    "Solution",
    "load",
    "solve",
    "reference",
    "devices",
    "Error",
    "FileError",
    "ResourceError",
    "DeviceError",
    "__version__",
]


class _Bars:
    """A progress callback that draws one tqdm bar per stage (plain lines on stderr when
    tqdm is not installed)."""

    def __init__(self):
        try:
            from tqdm.auto import tqdm
        except ImportError:
            tqdm = None
        self._tqdm = tqdm
        self._bar = None
        self._name = None

    def __call__(self, stage, done, total):
        if total == 0:
            self.close()
            if self._tqdm is None:
                print(f"meshrad: {stage}", file=sys.stderr, flush=True)
            return
        if self._tqdm is None:
            return
        if self._bar is None or self._name != stage:
            self.close()
            self._bar = self._tqdm(total=total, desc=stage, leave=False)
            self._name = stage
        self._bar.update(done - self._bar.n)

    def close(self):
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def _hook(progress):
    """The callback for `progress`: None/False (quiet), True (tqdm bars), or a callable
    `progress(stage: str, done: int, total: int)` (a stage begins with total == 0)."""
    if progress is None or progress is False:
        return None, None
    if progress is True:
        bars = _Bars()
        return bars, bars
    if callable(progress):
        return progress, None
    raise TypeError("progress: expected None, True or a callable (stage, done, total)")


def solve(scene, backend="auto", device=None, *, max_memory=None, progress=None, **solver_keys):
    """Solves `scene` and returns a `Solution`.

    backend: "auto" (a hardware GPU if there is one, else the CPU), "cpu" or "gpu".
    device: the Vulkan device by index or name substring (see `devices()`).
    max_memory: bytes, or a size such as "8G" (default: the scene's, from `load`).
    progress: None (quiet), True (tqdm bars) or a callable (stage, done, total).
    solver_keys: any [solver] key (rays=256, bounces=3, variant="approx", ...), checked
    as `meshrad solve --set KEY=VALUE` checks it.

    A scene never edited solves as `meshrad solve` does; once `Scene.edit` was called, as
    `meshrad session` does (reach = "object"; the hierarchy is built once and kept).
    Warnings the CLI prints (lights skipped, nothing lit) are Python warnings.
    """
    hook, bars = _hook(progress)
    try:
        sol = _meshrad.solve(scene, backend, device, max_memory, hook, solver_keys)
    finally:
        if bars is not None:
            bars.close()
    for w in sol.warnings:
        warnings.warn(w, RuntimeWarning, stacklevel=2)
    return sol


def reference(scene, points, samples=16384, max_bounces=0, seed=0x5EED, progress=None):
    """The independent brute-force reference at `points` ((N, 6) position, normal), as
    `meshrad reference --points`: direct light exact, indirect path-traced (the whole series,
    or `max_bounces` terms). Returns {"direct", "indirect", "total", "indirect_se"}, (N, 3)
    float64 arrays."""
    hook, bars = _hook(progress)
    try:
        return _meshrad.reference(scene, points, samples, max_bounces, seed, hook)
    finally:
        if bars is not None:
            bars.close()
