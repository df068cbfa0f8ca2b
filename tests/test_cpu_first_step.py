"""The cpu backend's first step on a new canvas writes no fresh pages of its own scratch
(issue 26 item 2): ``np.zeros`` only maps pages, and in this machine's VM each first write
of a 4 KiB page costs ~20-50 us, so the peer bench's 50 timed steps of a fresh 1024x1024
wash carried ~0.3 s of page faults in their first step. Counted with the process's minor
page faults, not timed."""

from __future__ import annotations

import resource

from station.backends.factory import create_backend
from station.bench._sim_driver import wash

N = 512


def _faults() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def test_a_new_canvas_first_step_faults_in_no_scratch_pages() -> None:
    warm = create_backend("cpu", N, N, "watercolor", 1, tiling=False)
    wash(warm, N, N)
    warm.step()  # kernels loaded or compiled, allocators warmed
    del warm
    canvas = create_backend("cpu", N, N, "watercolor", 1, tiling=False)
    wash(canvas, N, N)
    f0 = _faults()
    canvas.step()
    first = _faults() - f0
    # the scratch alone is ~25 fields of (N + 2)^2 float32: ~6400 pages of 4 KiB (main
    # faulted ~3400 of them in the first step, the rest reused from the first canvas)
    scratch_pages = 25 * (N + 2) ** 2 * 4 // 4096
    assert first < scratch_pages // 4, (first, scratch_pages)
    f0 = _faults()
    canvas.step()
    assert _faults() - f0 < scratch_pages // 4
