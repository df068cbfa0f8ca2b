"""The GPU canvas backend: moderngl compute shaders running the reference passes.

``GLCanvas`` implements the :class:`~station.backends.factory.CanvasBackend`
protocol; shaders live in ``station.shaders`` (the top-level ``shaders/``
folder) and share code through ``#include`` (see :mod:`.shaderlib`).
"""

from station.backends.gl import traffic
from station.backends.gl.canvas import GLCanvas, default_blur_rows, is_cpu_rasterizer
from station.glkit.context import GLUnavailable, create_context
from station.glkit.shaderlib import ShaderError

__all__ = ["GLCanvas", "GLUnavailable", "ShaderError", "create_context", "default_blur_rows",
           "is_cpu_rasterizer",
           "traffic"]
