"""The canvas backend protocol and the factory that picks an implementation.

Every backend simulates the same three-layer model (``reference.py`` is the
contract) and offers the same operations. Sources are given as float32 arrays of
any shape ``(h, w)`` placed with their top-left cell at row ``y0``, column ``x0``
of the canvas (clipped to the canvas): ``dw`` water height, ``dp`` pigment area
fraction per pigment name, ``dvx``/``dvy`` velocity [cell/s]. Masked cells
receive nothing. Unknown pigments, or a ninth pigment in one layer, raise
``BadInput`` without changing the canvas.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Protocol, runtime_checkable

import numpy as np

from station.canvas.params import CanvasInputError
from station.canvas.state import CanvasState

BACKENDS = ("numpy", "gl", "cpu")


def numba_available() -> bool:
    """Whether the ``cpu`` backend can run (numba importable)."""
    import importlib.util

    return importlib.util.find_spec("numba") is not None


def fastest_cpu_backend() -> str:
    """The backend to use without a GPU: ``"cpu"`` (numba) when numba is installed,
    else the ``"numpy"`` reference. ``create_backend("auto", ...)`` makes this one."""
    return "cpu" if numba_available() else "numpy"


@runtime_checkable
class CanvasBackend(Protocol):
    """What the session player, the live simulation and the benchmark drive."""

    @property
    def renderer(self) -> str:
        """"numpy", or the GL_RENDERER string of the GL backend."""
        ...

    @property
    def width(self) -> int:
        ...

    @property
    def height(self) -> int:
        ...

    def add_sources(self, dw: np.ndarray | None = None,
                    dp: Mapping[str, np.ndarray] | None = None,
                    dvx: np.ndarray | None = None, dvy: np.ndarray | None = None,
                    *, y0: int = 0, x0: int = 0) -> None:
        """Add brush/tool sources (spec step 1) at ``(y0, x0)``."""
        ...

    def step(self, dt: float | None = None) -> None:
        """One simulation step (``params.dt`` when ``dt`` is None)."""
        ...

    def dry(self) -> None:
        """Dry the active layer: suspended pigment settles, all water goes."""
        ...

    def new_layer(self) -> None:
        """Dry, fold the active layer into the composed reflectance, start a new one."""
        ...

    def clear(self) -> None:
        """Back to blank paper (same paper, same profile), bookkeeping reset."""
        ...

    def set_profile(self, name: str) -> None:
        """Switch paint profile (parameters, renderer, palette defaults) mid-painting."""
        ...

    def render(self) -> np.ndarray:
        """Linear reflectance, float32 (H, W, 3) in [0, 1]."""
        ...

    def state(self) -> CanvasState:
        """A copy of the complete state (GPU backends read their textures back)."""
        ...

    def load_state(self, state: CanvasState) -> None:
        """Continue from ``state`` exactly."""
        ...

    def stats(self) -> dict[str, Any]:
        """The ``--stats`` JSON of interfaces.md."""
        ...


def create_backend(name: str, width: int, height: int, profile: str = "watercolor",
                   seed: int = 0, **opts: Any) -> CanvasBackend:
    """Make a backend: ``"numpy"`` (reference), ``"gl"`` (moderngl, imported lazily),
    ``"cpu"`` (the reference fused and compiled with numba, imported lazily) or
    ``"auto"`` (:func:`fastest_cpu_backend`: ``cpu`` when numba is installed, else
    ``numpy``; GL is only made when asked for by name).

    ``opts`` go to the backend (e.g. ``tiling=False``, ``n_slots=8``,
    ``params=SimParams(...)`` overriding the profile's parameters).
    """
    if name == "auto":
        name = fastest_cpu_backend()
    if name == "cpu":
        import importlib

        cpu = importlib.import_module("station.canvas.cpu")  # lazy: numba only when asked
        made: CanvasBackend = cpu.CpuCanvas(width, height, profile=profile, seed=seed, **opts)
        return made
    if name == "numpy":
        from station.canvas.numpy_backend import NumpyCanvas

        return NumpyCanvas(width, height, profile=profile, seed=seed, **opts)
    if name == "gl":
        import importlib

        gl = importlib.import_module("station.canvas.gl")  # lazy: moderngl only when asked
        backend: CanvasBackend = gl.GLCanvas(width, height, profile=profile, seed=seed, **opts)
        return backend
    raise CanvasInputError(
        f"unknown canvas backend {name!r} (known: {', '.join(BACKENDS)})", "--backend")
