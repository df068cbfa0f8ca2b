"""The OpenGL context of the GPU canvas and the limits the passes depend on.

Headless by default: ``moderngl.create_context(standalone=True, backend='egl')``
gives Mesa's llvmpipe on a machine without a GPU and the vendor driver on a
machine with one; nothing here depends on which.  Limits (work-group size,
texture size) are queried, never assumed.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from station.errors import StationError

if TYPE_CHECKING:  # moderngl is an optional extra, imported where a context is made
    import moderngl

#: GL 4.3 is the first version with compute shaders and image load/store in core.
REQUIRED_GL_VERSION = 430


class GLUnavailable(StationError):
    """No usable OpenGL 4.3+ context could be created (no EGL, no driver, too old)."""


@dataclass(frozen=True)
class GLLimits:
    """Implementation limits the canvas checks before it allocates anything."""

    renderer: str
    version_code: int
    max_texture_size: int
    max_work_group_invocations: int
    max_work_group_size: tuple[int, int, int]
    max_work_group_count: tuple[int, int, int]


def create_context(backend: str | None = None) -> Any:
    """A standalone moderngl context (EGL unless ``backend``/``STATION_GL_BACKEND`` say else).

    ``backend=""`` (or ``STATION_GL_BACKEND=default``) lets moderngl pick its
    platform default (GLX/WGL/CGL), for machines with a display but no EGL.
    Raises :class:`GLUnavailable` with the driver's reason when it fails.
    """
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - moderngl is a dependency
        raise GLUnavailable(f"moderngl is not installed: {exc}") from exc
    if backend is None:
        backend = os.environ.get("STATION_GL_BACKEND", "egl")
    kwargs: dict[str, Any] = {"standalone": True, "require": REQUIRED_GL_VERSION}
    if backend and backend != "default":
        kwargs["backend"] = backend
    try:
        ctx = moderngl.create_context(**kwargs)
    except Exception as exc:  # moderngl raises plain Exception for a missing EGL
        raise GLUnavailable(f"cannot create an OpenGL {REQUIRED_GL_VERSION // 100}."
                            f"{REQUIRED_GL_VERSION % 100 // 10} context "
                            f"(backend {backend or 'default'}): {exc}") from exc
    if ctx.version_code < REQUIRED_GL_VERSION:
        version = ctx.version_code
        ctx.release()
        raise GLUnavailable(f"OpenGL {version} is too old; compute shaders need 430")
    return ctx


def query_limits(ctx: moderngl.Context) -> GLLimits:
    """Read the limits of ``ctx`` that the canvas uses."""
    info = ctx.info
    return GLLimits(
        renderer=str(info.get("GL_RENDERER", "unknown")),
        version_code=int(ctx.version_code),
        max_texture_size=int(info.get("GL_MAX_TEXTURE_SIZE", 2048)),
        max_work_group_invocations=int(info.get("GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS", 1024)),
        max_work_group_size=tuple(info.get("GL_MAX_COMPUTE_WORK_GROUP_SIZE", (1024, 1024, 64))),
        max_work_group_count=tuple(info.get("GL_MAX_COMPUTE_WORK_GROUP_COUNT",
                                            (65535, 65535, 65535))),
    )
