"""The ``cpu`` canvas backend: the reference model compiled with numba, fused and parallel.

Importing this package needs numba (:func:`station.backends.factory.numba_available`
says whether it is installed).
"""

import os

# libgomp threads that spin while waiting stall a 2-thread parallel region when another
# process holds the second core (measured: 12 vs 58 steps/s on the 800x600 wash); passive
# waiting costs ~3 % on a quiet machine. Read once, when the OpenMP runtime loads.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from station.backends.cpu.canvas import CpuCanvas

__all__ = ["CpuCanvas"]
