"""The cpu kernels' parallel warm-up (station.backends.cpu.warm): each share compiles only
its kernels, for the types a real step passes, and leaves the modules as it found them."""

from __future__ import annotations

import subprocess
import sys

import pytest

from station.backends.cpu import fused as F
from station.backends.cpu import kernels as K
from station.backends.cpu import warm


def test_the_shares_split_the_steps_parallel_kernels() -> None:
    kernels = warm.parallel_kernels()
    assert {"prep", "advect_jacobi1", "limit_diffuse_fused", "advect_fused",
            "evap_cap_fused"} <= set(kernels)
    shares = [{n for n in kernels if warm.share_of(n) == k} for k in range(warm.SHARES)]
    assert all(shares) and set.union(*shares) == set(kernels)
    assert set(warm.FIRST) <= shares[0]


def test_a_share_skips_the_other_shares_kernels_and_restores_them(
        monkeypatch: pytest.MonkeyPatch) -> None:
    kernels = warm.parallel_kernels()
    skipped: list[str] = []

    def skip(name: str) -> object:
        def run(*_a: object) -> None:
            skipped.append(name)
        return run

    monkeypatch.setattr(warm, "_skipper", skip)
    got = warm.compile_share(1)
    assert {"evap_cap_fused", "advect_jacobi1"} <= set(got)
    assert set(warm.FIRST) <= set(skipped)  # the step called them: skipped
    assert not set(skipped) - set(warm.FIRST)
    assert K.prep is kernels["prep"][1] and F.evap_cap_fused is kernels["evap_cap_fused"][1]


def test_bad_jobs_is_refused_in_one_line() -> None:
    proc = subprocess.run([sys.executable, "-m", "station.backends.cpu.warm", "--jobs", "0"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "--jobs 0" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_the_first_share_leaves_its_kernels_compiled() -> None:
    assert set(warm.FIRST) <= set(warm.compile_share(0))
