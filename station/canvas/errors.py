"""The canvas layer's typed error (its own module so every canvas module can raise it
without importing the parameter module)."""

from __future__ import annotations

from station.errors import BadInput


class CanvasInputError(BadInput):
    """Bad input to the canvas (pigment, profile, size, state file, parameter)."""
