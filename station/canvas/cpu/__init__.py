"""The ``cpu`` canvas backend: the reference model compiled with numba, fused and parallel.

Importing this package needs numba (``NUMBA_AVAILABLE`` in :mod:`station.canvas.backend`
says whether it is installed).
"""

from station.canvas.cpu.canvas import CpuCanvas

__all__ = ["CpuCanvas"]
