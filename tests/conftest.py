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
