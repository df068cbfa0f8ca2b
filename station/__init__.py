"""The painting station: pen tablets drive a physically-based watery-paint simulation."""

from station import vectors as _vectors

__version__ = "0.1.0"

# before any station module imports numba: its kernels' vector width (station/vectors.py)
_vectors.install()
