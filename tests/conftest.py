"""Shared test fixtures: every test gets private runtime and config directories."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from station.pictures import effects_core


@pytest.fixture(scope="session")
def _station_cache_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One cache per test worker: ``auto``'s backend probe runs once per worker, not
    once per test, and never touches the user's ~/.cache."""
    return tmp_path_factory.mktemp("station-cache")


@pytest.fixture(autouse=True)
def _private_station_dirs(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch,
    _station_cache_dir: Path,
) -> None:
    base = tmp_path_factory.mktemp("station-env")
    # Short paths: ipc socket paths must stay under the ~107-byte sun_path limit.
    run = Path(f"/tmp/st-{os.getpid()}-{base.name[-6:]}")
    monkeypatch.setenv("STATION_RUNTIME_DIR", str(run))
    monkeypatch.setenv("STATION_CONFIG_DIR", str(base / "config"))
    monkeypatch.setenv("STATION_DATA_DIR", str(base / "data"))
    monkeypatch.setenv("STATION_CACHE_DIR", str(_station_cache_dir))


def _no_pty_reason() -> str | None:
    """The serial haptic mock lives on a pseudo-terminal pair; a chroot without /dev/pts
    (such as the fresh-machine check's) has none."""
    try:
        master, slave = os.openpty()
    except OSError as exc:
        return f"no pseudo-terminals here ({exc}; is /dev/pts mounted?)"
    os.close(master)
    os.close(slave)
    return None


NO_PTY = _no_pty_reason()
needs_pty = pytest.mark.skipif(NO_PTY is not None, reason=NO_PTY or "")


@pytest.fixture(autouse=True)
def _effects_on_cpu() -> None:
    """The brush tiles paint on the cpu backend: bit for bit the numpy reference
    (tests/test_cpu_backend.py holds them together) in a fraction of its time, which keeps
    ``make test`` inside its budget. ``station effects`` itself paints on numpy."""
    effects_core.use_backend("cpu")
