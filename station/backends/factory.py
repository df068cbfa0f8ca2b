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

import importlib
import importlib.util
import logging
from collections.abc import Mapping
from typing import Any, Protocol, runtime_checkable

import numpy as np

from station.canvas.params import CanvasInputError
from station.canvas.state import CanvasState
from station.errors import BadInput, StationError

log = logging.getLogger(__name__)

BACKENDS = ("numpy", "gl", "cpu")


def numba_available() -> bool:
    """Whether the ``cpu`` backend can run (numba importable)."""
    return importlib.util.find_spec("numba") is not None


def fastest_cpu_backend() -> str:
    """The backend to use without a GPU: ``"cpu"`` (numba) when numba is installed,
    else the ``"numpy"`` reference."""
    return "cpu" if numba_available() else "numpy"


SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "lavapipe", "software rasterizer")
"""GL_RENDERER words of OpenGL implementations that run on the CPU."""


def _gl_renderer() -> str:
    """GL_RENDERER of a fresh context; :class:`StationError` or ImportError if none."""
    from station.glkit.context import create_context  # lazy: moderngl only when probed

    ctx = create_context()
    try:
        return str(ctx.info.get("GL_RENDERER", "unknown"))
    finally:
        ctx.release()


def _one_line(exc: BaseException) -> str:
    return " | ".join(ln.strip() for ln in str(exc).splitlines() if ln.strip())[:300]


def resolve_auto() -> tuple[str, str]:
    """What ``--backend auto`` means on this machine, and why (one line).

    The only place that decides it: ``gl`` when an OpenGL 4.3 context runs on a real
    GPU; otherwise :func:`fastest_cpu_backend` (``cpu`` with numba, else ``numpy``),
    also when the context is a CPU rasterizer such as Mesa llvmpipe, where the CPU
    backends are faster (docs/gpu.md, docs/cpu-backend.md: on the 2-core machine at
    800x600 llvmpipe GL did 73 stroke steps/s, NumPy 95, cpu 5-8x NumPy).
    """
    cpu = fastest_cpu_backend()
    try:
        renderer = _gl_renderer()
    except (ImportError, StationError) as exc:
        return cpu, f"GL unavailable ({_one_line(exc)})"
    if any(k in renderer.lower() for k in SOFTWARE_GL):
        return cpu, f"OpenGL renderer {renderer!r} runs on the CPU, where {cpu} is faster"
    return "gl", f"OpenGL renderer {renderer!r}"


def available_backends() -> list[str]:
    """Every backend that can run here: ``numpy`` always, ``cpu`` with numba, ``gl``
    when an OpenGL 4.3 context can be made (a CPU rasterizer counts)."""
    names = ["numpy"]
    if numba_available():
        names.append("cpu")
    try:
        _gl_renderer()
    except (ImportError, StationError):
        pass
    else:
        names.append("gl")
    return names


def make_backend(name: str, width: int, height: int, profile: str = "watercolor",
                 seed: int = 0, **opts: Any) -> tuple[CanvasBackend, str]:
    """Create backend ``name`` (``auto`` through :func:`resolve_auto`); returns it and
    the name of the one made.

    An explicit ``gl`` that cannot start is an environment failure (exit 1), not bad
    input; ``auto`` then falls back to :func:`fastest_cpu_backend` with a one-line
    warning.
    """
    if name == "auto":
        name, why = resolve_auto()
        log.info("backend auto: %s (%s)", name, why)
        if name == "gl":
            try:
                return create_backend("gl", width, height, profile, seed, **opts), "gl"
            except BadInput:
                raise
            except (ImportError, StationError) as exc:
                name = fastest_cpu_backend()
                log.warning("GL backend unavailable (%s): painting with %s",
                            _one_line(exc), name)
    try:
        return create_backend(name, width, height, profile, seed, **opts), name
    except ImportError as exc:
        raise StationError(f"backend {name!r} cannot be loaded: {exc}") from None


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
    ``"auto"`` (:func:`resolve_auto` decides, through :func:`make_backend`).

    ``opts`` go to the backend (e.g. ``tiling=False``, ``n_slots=8``,
    ``params=SimParams(...)`` overriding the profile's parameters).
    """
    if name == "auto":
        return make_backend("auto", width, height, profile, seed, **opts)[0]
    if name == "cpu":
        cpu = importlib.import_module("station.backends.cpu")  # lazy: numba only when asked
        made: CanvasBackend = cpu.CpuCanvas(width, height, profile=profile, seed=seed, **opts)
        return made
    if name == "numpy":
        from station.backends.numpy_canvas import NumpyCanvas

        return NumpyCanvas(width, height, profile=profile, seed=seed, **opts)
    if name == "gl":
        gl = importlib.import_module("station.backends.gl")  # lazy: moderngl only when asked
        backend: CanvasBackend = gl.GLCanvas(width, height, profile=profile, seed=seed, **opts)
        return backend
    raise CanvasInputError(
        f"unknown canvas backend {name!r} (known: {', '.join(BACKENDS)})", "--backend")
