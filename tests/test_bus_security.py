"""Bus security (issue 8, item 4): user-named directories untouched, rejected CURVE peers
logged with their key, one client key per driver."""

from __future__ import annotations

import logging
import os
import stat
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
import zmq

from station.bus import Publisher, Subscriber, add_client_key, generate_keys, runtime_dir
from station.errors import BusConfigError, BusError
from station.events import PenSample, Tool


@pytest.mark.parametrize("mode", [0o755, 0o1777, 0o775])
def test_binding_an_explicit_ipc_path_never_changes_its_directory(tmp_path: Path,
                                                                  mode: int) -> None:
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, mode)
    with Publisher(f"ipc://{shared}/bus") as pub:
        assert stat.S_IMODE(shared.stat().st_mode) == mode
        assert stat.S_IMODE(Path(pub.url[6:]).stat().st_mode) == 0o600  # our socket only
    with Subscriber(f"@ipc://{shared}/sub"):
        assert stat.S_IMODE(shared.stat().st_mode) == mode


def test_an_explicit_ipc_directory_is_never_created(tmp_path: Path) -> None:
    missing = tmp_path / "nope"
    with pytest.raises(BusError, match="does not exist"):
        Publisher(f"ipc://{missing}/bus")
    assert not missing.exists()


def test_the_station_runtime_directory_is_still_0700() -> None:
    with Publisher("ipc:own") as pub:
        assert Path(pub.url[6:]).parent == runtime_dir()
        assert stat.S_IMODE(runtime_dir().stat().st_mode) == 0o700


def _receive(sub: Subscriber, got: list[Any], want: int, seconds: float) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline and len(got) < want:
        m = sub.recv(20)
        if m is not None:
            got.append(m)


def test_each_driver_its_own_key_and_rejected_peers_are_logged(tmp_path: Path,
                                                               caplog: Any) -> None:
    """The sim binds tcp (CURVE server); two drivers connect with keys of their own.
    Revoking one key shuts that driver out, and the ZAP handler logs its public key."""
    keys = tmp_path / "keys"
    generate_keys(keys)
    add_client_key("tab1", keys)
    tab2 = add_client_key("tab2", keys)
    with pytest.raises(BusConfigError, match="exists"):
        add_client_key("tab2", keys)
    (keys / "authorized" / "client-tab2.key").unlink()  # revoke tab2
    tab2_public = next(ln.split('"')[1] for ln in tab2.read_text().splitlines()
                       if ln.strip().startswith("public-key"))
    ctx = zmq.Context()
    port = 40000 + os.getpid() % 9000
    endpoint = f"tcp://127.0.0.1:{port}"
    caplog.set_level(logging.WARNING, logger="station.bus")
    sub = Subscriber("@" + endpoint, topics=("pen.",), keys=keys, context=ctx)
    got: list[Any] = []
    t = threading.Thread(target=_receive, args=(sub, got, 10, 6.0))
    t.start()
    pubs = {name: Publisher(">" + endpoint, keys=keys, client_key=name, context=ctx)
            for name in ("tab1", "tab2")}
    assert pubs["tab1"].wait_for_subscribers(1, 5)
    assert not pubs["tab2"].wait_for_subscribers(1, 1.0)
    for name, pub in pubs.items():
        for i in range(1, 6):
            pub.publish_pen(PenSample(t=i / 100, device=name, tool=Tool.PEN, x=0.5, y=0.5,
                                      seq=i))
    t.join()
    assert sorted({m.value.device for m in got}) == ["tab1"] and len(got) == 5
    rejected = [r.getMessage() for r in caplog.records if "rejected a CURVE peer" in
                r.getMessage()]
    assert len(rejected) == 1 and tab2_public in rejected[0]  # once, with its key
    for pub in pubs.values():
        pub.close()
    sub.close()
    ctx.destroy(linger=0)


def test_keys_cli_adds_a_driver_key_and_driver_flag_uses_it(tmp_path: Path) -> None:
    keys = tmp_path / "k"

    def station(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "station", *args], capture_output=True,
                              text=True, timeout=60)

    no_server = station("keys", "--dir", str(keys), "--client", "tab1")
    assert no_server.returncode == 2 and "run 'station keys' first" in no_server.stderr
    assert station("keys", "--dir", str(keys)).returncode == 0
    made = station("keys", "--dir", str(keys), "--client", "tab1")
    assert made.returncode == 0, made.stderr
    assert (keys / "client-tab1.key_secret").exists()
    assert (keys / "authorized" / "client-tab1.key").exists()
    assert stat.S_IMODE((keys / "client-tab1.key_secret").stat().st_mode) == 0o600
    bad = station("keys", "--dir", str(keys), "--client", "../x")
    assert bad.returncode == 2 and "client key name" in bad.stderr
    missing = station("driver", "--device", "mock:intuos-pro-m?script=line&speed=max",
                      "--bus", ">tcp://127.0.0.1:9", "--keys", str(keys), "--client-key",
                      "nobody")
    assert missing.returncode == 2 and "client-nobody" in missing.stderr


def test_keys_never_chmod_a_directory_the_user_named(tmp_path: Path) -> None:
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, 0o755)
    r = subprocess.run([sys.executable, "-m", "station", "keys", "--dir", str(shared)],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "open to other users" in r.stderr
    assert stat.S_IMODE(shared.stat().st_mode) == 0o755 and not list(shared.iterdir())
