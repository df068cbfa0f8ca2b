"""numba's vector width (station/vectors.py): every station process that compiles kernels
on an AVX-512 machine does so for 512-bit vectors, whatever numba user it imports first,
and nothing changes elsewhere. The kernels' bits under it: tests/test_cpu_backend.py and
tests/test_canvas_passes.py run in a process set up this way (the first test here says so)."""

from __future__ import annotations

import os
import subprocess
import sys

import llvmlite.binding as llvm
import pytest

from station import vectors

AVX512 = "+avx512f" in llvm.get_host_cpu_features().flatten().split(",")
HOST = "+64bit,+avx,+avx2,+avx512f,+avx512bw,-amx-avx512,+fma"


def test_the_test_process_compiles_for_512_bit_vectors_where_the_cpu_has_them() -> None:
    # conftest imports station before any numba user: the cpu backend's bitwise tests
    # in this process hold numpy == cpu for the kernels as the station runs them
    assert vectors.active() is AVX512


def test_wide_features_drop_the_256_bit_tuning_only_on_avx512_hosts() -> None:
    assert vectors.wide_features(HOST) == HOST + ",-prefer-256-bit"
    assert vectors.wide_features(HOST.replace("+avx512f", "-avx512f")) is None
    assert vectors.wide_features("+64bit,+avx,+avx2,+fma") is None
    assert vectors.wide_features(HOST + ",-prefer-256-bit") is None  # once only
    assert vectors.wide_features("") is None


def _fresh(code: str, **env: str) -> str:
    """``code`` in a new interpreter (the width is fixed once a process): its stdout."""
    full = {k: v for k, v in os.environ.items()
            if k not in ("NUMBA_CPU_FEATURES", "NUMBA_CPU_NAME", vectors.ENV_OFF)}
    full.update(env)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, env=full, check=True)
    return out.stdout.strip()


ASM = """
import numba, numpy as np
@numba.njit(fastmath=False, error_model="numpy")
def f(a, o):
    for i in range(a.shape[0]):
        o[i] = a[i] / (a[i] + np.float32(1.0))
a = np.ones(64, np.float32); f(a, a.copy())
asm = "".join(f.inspect_asm().values())
"""


@pytest.mark.parametrize("first", [
    "import station.backends.cpu.kernels",   # the cpu backend
    "import station.render.km_fast",         # another numba user of the station
    "import numba\nimport station",          # numba itself, before any dispatcher
    # looked for before it is imported (backends.factory.numba_available)
    "import importlib.util, station\nassert importlib.util.find_spec('numba')\n"
    "import station.backends.cpu.kernels",
])
def test_any_import_order_gets_the_wide_vectors(first: str) -> None:
    code = f"{first}\nfrom station import vectors\n{ASM}\nprint(vectors.active(), 'zmm' in asm)"
    want = f"{AVX512} {AVX512}"
    assert _fresh(code) == want


def test_the_width_stays_as_llvm_tunes_it_when_asked_or_set_by_numba_s_own_variables() -> None:
    code = f"import station.backends.cpu.kernels\nfrom station import vectors\n{ASM}\n" \
           "print(vectors.active(), 'zmm' in asm)"
    assert _fresh(code, **{vectors.ENV_OFF: "0"}) == "False False"
    assert _fresh(code, NUMBA_CPU_FEATURES="+64bit,+sse2") == "False False"


def test_a_dispatcher_made_before_station_is_imported_keeps_numba_s_choice() -> None:
    code = ("import numba\n@numba.njit\ndef g(x):\n    return x\n"
            "import station\nfrom station import vectors\nprint(vectors.active())")
    assert _fresh(code) == "False"
