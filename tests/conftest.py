"""Shared test fixtures: every test gets private runtime and config directories."""

from __future__ import annotations

import os
from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def _private_station_dirs(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    base = tmp_path_factory.mktemp("station-env")
    # Short paths: ipc socket paths must stay under the ~107-byte sun_path limit.
    run = Path(f"/tmp/st-{os.getpid()}-{base.name[-6:]}")
    monkeypatch.setenv("STATION_RUNTIME_DIR", str(run))
    monkeypatch.setenv("STATION_CONFIG_DIR", str(base / "config"))
    monkeypatch.setenv("STATION_DATA_DIR", str(base / "data"))


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
