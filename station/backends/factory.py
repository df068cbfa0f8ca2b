"""The factory that picks a canvas backend (:mod:`station.backends.protocol` is what
every one offers).

Every backend simulates the same three-layer model (``canvas/reference.py`` is the
contract) and offers the same operations. Sources are given as float32 arrays of
any shape ``(h, w)`` placed with their top-left cell at row ``y0``, column ``x0``
of the canvas (clipped to the canvas): ``dw`` water height, ``dp`` pigment area
fraction per pigment name, ``dvx``/``dvy`` velocity [cell/s]. Masked cells
receive nothing. Unknown pigments, or a ninth pigment in one layer, raise
``BadInput`` without changing the canvas.
"""

from __future__ import annotations

import importlib.util
import logging
from typing import TYPE_CHECKING, Any

from station.backends import choice
from station.backends.choice import Choice
from station.backends.numpy_canvas import NumpyCanvas
from station.backends.protocol import CanvasBackend
from station.canvas.params import CanvasInputError
from station.errors import BadInput, StationError

if TYPE_CHECKING:
    from station.backends.distributed.canvas import DistributedCanvas

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
    # in the function: moderngl only when a GL context is probed
    from station.glkit.context import create_context

    ctx = create_context()
    try:
        return str(ctx.info.get("GL_RENDERER", "unknown"))
    finally:
        ctx.release()


def _one_line(exc: BaseException) -> str:
    return " | ".join(ln.strip() for ln in str(exc).splitlines() if ln.strip())[:300]


def fixed_rule(renderer: str | None, gl_problem: str = "") -> tuple[str, str]:
    """The rule ``auto`` followed before issue 26, now only where nothing could be
    measured: ``gl`` on a real GPU, otherwise :func:`fastest_cpu_backend` (also on a
    CPU rasterizer such as Mesa llvmpipe)."""
    cpu = fastest_cpu_backend()
    if renderer is None:
        return cpu, f"GL unavailable ({gl_problem})"
    if any(k in renderer.lower() for k in SOFTWARE_GL):
        return cpu, f"OpenGL renderer {renderer!r} runs on the CPU, where {cpu} is faster"
    return "gl", f"OpenGL renderer {renderer!r}"


def auto_choice() -> Choice:
    """What ``--backend auto`` means on this machine, with its figures: the cached
    measurement of :mod:`station.backends.choice`, or a fresh one (a short bounded
    probe of every backend available here; then cached)."""
    numba = numba_available()
    candidates = ["numpy"] + (["cpu"] if numba else [])
    renderer: str | None = None
    problem = ""
    try:
        renderer = _gl_renderer()
    except (ImportError, StationError) as exc:
        problem = _one_line(exc)
    else:
        candidates.append("gl")
    # make=None: the probe runs in a child process (its GL contexts stay out of ours)
    return choice.resolve(candidates, renderer, choice.machine_key(numba), None,
                          fixed_rule(renderer, problem)[0])


def resolve_auto() -> tuple[str, str]:
    """What ``--backend auto`` means on this machine, and why (one line).

    The only place that decides it: the fastest backend measured here
    (:func:`auto_choice`; on the 2-core machine cpu beats llvmpipe's GL and NumPy,
    on a machine with a GPU GL should win: measured, not assumed)."""
    c = auto_choice()
    return c.backend, c.why + (" (cached)" if c.cached else "")


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
        # in the function: numba (about half a second to import) only when asked
        from station.backends.cpu import CpuCanvas

        return CpuCanvas(width, height, profile=profile, seed=seed, **opts)
    if name == "numpy":
        return NumpyCanvas(width, height, profile=profile, seed=seed, **opts)
    if name == "gl":
        # in the function: moderngl and a GL context only when asked (optional on a
        # headless machine without EGL)
        from station.backends.gl import GLCanvas

        return GLCanvas(width, height, profile=profile, seed=seed, **opts)
    raise CanvasInputError(
        f"unknown canvas backend {name!r} (known: {', '.join(BACKENDS)})", "--backend")


def create_distributed(name: str, width: int, height: int, profile: str, seed: int,
                       **opts: Any) -> tuple[DistributedCanvas, str]:
    """A :class:`~station.backends.distributed.canvas.DistributedCanvas` stepping ``name``
    (``auto``: cpu when numba is installed, else numpy) on every rank's strip; returns it
    and its name (``distributed-<name>``)."""
    if name == "auto":
        name = fastest_cpu_backend()
    if name not in ("numpy", "cpu"):
        raise CanvasInputError(f"--distributed steps the numpy or cpu backend, not {name!r}",
                               "--backend")
    try:
        # in the function: mpi4py and an MPI library are the optional ``mpi`` extra
        from station.backends.distributed.canvas import DistributedCanvas
    except ImportError as exc:
        raise StationError(f"--distributed needs mpi4py and an MPI library (pip install "
                           f"'painting-station[mpi]'): {exc}") from None
    canvas = DistributedCanvas(width, height, profile, seed, base=name, **opts)
    return canvas, f"distributed-{name}"
