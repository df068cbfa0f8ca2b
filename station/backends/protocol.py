"""The canvas backend protocol: what the session player, the live simulation, the
picture makers and the benchmarks drive, whichever backend runs the model.

Sources are given as float32 arrays of any shape ``(h, w)`` placed with their
top-left cell at row ``y0``, column ``x0`` of the canvas (clipped to the canvas):
``dw`` water height, ``dp`` pigment area fraction per pigment name, ``dvx``/``dvy``
velocity [cell/s]. Masked cells receive nothing. Unknown pigments, or a ninth
pigment in one layer, raise ``BadInput`` without changing the canvas.

Tool operations (the hair dryer, masking fluid, eraser, tissue, the diffusion
controller, a tilt) are :data:`StateEdit` functions of a :class:`CanvasState`; the
caller that holds the tool (the session player) hands one to :func:`edit_state`, so
the canvas model never calls up into the rooms that hold the tools.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Protocol, TypeVar, runtime_checkable

import numpy as np

from station.canvas.state import CanvasState
from station.canvas.stats import CanvasStats

T = TypeVar("T")

StateEdit = Callable[[CanvasState], T]
"""A tool operation: changes a canvas state in place (and books what it removes),
returns what the tool reports (e.g. the cells a dab hit)."""


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

    def stats(self) -> CanvasStats:
        """The ``--stats`` JSON of interfaces.md."""
        ...


@runtime_checkable
class LiveStateBackend(CanvasBackend, Protocol):
    """A backend that keeps its state in memory (numpy, cpu): tools edit it in place."""

    @property
    def live_state(self) -> CanvasState:
        """The backend's own state (not a copy)."""
        ...


def edit_state(backend: CanvasBackend, edit: StateEdit[T]) -> T:
    """Run the tool operation ``edit`` on the backend's canvas state and keep what it
    changed: in place on the NumPy and cpu backends (``live_state``), through a state
    round trip elsewhere (GL)."""
    live = getattr(backend, "live_state", None)
    if isinstance(live, CanvasState):
        return edit(live)
    st = backend.state()
    out = edit(st)
    backend.load_state(st)
    return out
