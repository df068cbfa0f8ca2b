"""The GPU canvas backend: moderngl compute shaders running the reference passes.

``GLCanvas`` implements the :class:`~station.canvas.backend.CanvasBackend`
protocol; shaders live in ``station.shaders`` (the top-level ``shaders/``
folder) and share code through ``#include`` (see :mod:`.shaderlib`).
"""

from station.canvas.gl import traffic
from station.canvas.gl.canvas import GLCanvas
from station.canvas.gl.context import GLUnavailable, create_context
from station.canvas.gl.shaderlib import ShaderError

__all__ = ["GLCanvas", "GLUnavailable", "ShaderError", "create_context", "traffic"]
