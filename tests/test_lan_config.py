"""What a configuration names reaches no further than it should (issue 25 item 2): a
runtime directory the user named is never chmod-ed, CURVE keys others can read are
refused with what to chmod, autosaves are private like their logs."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from station.bus import generate_keys, load_keys, runtime_dir
from station.cli import main
from station.errors import BusConfigError
from station.events import PenSample, Tool
from station.sim.live import LiveConfig, LiveCore


@pytest.mark.parametrize("mode", [0o1777, 0o755, 0o770])
def test_a_named_runtime_dir_open_to_others_is_refused_never_chmod_ed(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, mode: int) -> None:
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, mode)
    monkeypatch.setenv("STATION_RUNTIME_DIR", str(shared))
    with pytest.raises(BusConfigError, match="chmod 700"):
        runtime_dir()
    assert stat.S_IMODE(shared.stat().st_mode) == mode


def test_keys_open_to_others_are_refused_with_what_to_chmod(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    keys = tmp_path / "keys"
    keys.mkdir(mode=0o700)
    generate_keys(keys)
    load_keys(keys)  # private: fine
    load_keys(keys, role="client")
    os.chmod(keys / "server.key_secret", 0o644)
    with pytest.raises(BusConfigError, match=f"chmod 600 {keys}/server.key_secret"):
        load_keys(keys)
    os.chmod(keys / "server.key_secret", 0o600)
    os.chmod(keys / "client.key_secret", 0o640)
    with pytest.raises(BusConfigError, match="chmod 600"):
        load_keys(keys, role="client")
    os.chmod(keys / "client.key_secret", 0o600)
    os.chmod(keys, 0o755)
    with pytest.raises(BusConfigError, match=f"chmod 700 {keys}"):
        load_keys(keys)
    assert stat.S_IMODE(keys.stat().st_mode) == 0o755  # told, not changed
    # the CLI: exit 2, one line
    code = main(["bus", "--pub", "tcp://127.0.0.1:1", "--sub", "tcp://127.0.0.1:2",
                 "--keys", str(keys)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "chmod 700" in err[0], err


def test_autosaves_are_private_like_the_log(tmp_path: Path) -> None:
    core = LiveCore(LiveConfig(bus=None, width=24, height=16, backend="numpy", rate=40.0,
                               log_path=str(tmp_path / "s.jsonl"), autosave=0.0))
    for i in range(4):
        core.feed_sample(PenSample(t=i * 0.01, device="d", tool=Tool.PEN, x=0.2 + 0.1 * i,
                                   y=0.5, pressure=0.7, touching=True, seq=i + 1))
        core.step()
    os.umask(old := os.umask(0o022))
    try:
        assert core.autosave()
    finally:
        os.umask(old)
    assert stat.S_IMODE(core.autosave_path.stat().st_mode) == 0o600
    assert stat.S_IMODE(core.log_path.stat().st_mode) == 0o600
