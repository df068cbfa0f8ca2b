"""The three-layer watery-paint canvas (WaterVerve, seed chapters 4 and 6).

``create_backend(name, width, height, profile, seed)`` gives a backend ("numpy"
reference or "gl"); ``reference.py`` holds the pass list that both implement.
"""

from station.canvas.backend import BACKENDS, CanvasBackend, create_backend

__all__ = ["BACKENDS", "CanvasBackend", "create_backend"]
