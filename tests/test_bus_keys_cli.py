"""CURVE keys for the bus's clients (`station sim`, `record`, `replay`, `send`, `kiosk`)
and for the blueprint's tcp consumers: a keyed client receives over tcp what a keyed
publisher sends, a key not authorised gets nothing (the binding side logs and counts
it), a tcp endpoint without keys is exit 2 with one line."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import zmq
from kiosk_harness import SCREEN, xvfb
from kiosk_harness import station as kstation
from livesim import stop as finish
from station.drivers import synth
from station.drivers.mock.tablet import MockTablet, find_model

from station.blueprint import doctor
from station.blueprint.load import load
from station.blueprint.model import BlueprintError
from station.blueprint.plan import resolve
from station.blueprint.systemd import units
from station.bus import Publisher, Subscriber, add_client_key, generate_keys
from station.cli import build_parser
from station.events import PenSample, Tool

STATION = [sys.executable, "-m", "station"]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def station(*args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*STATION, *args], capture_output=True, text=True, timeout=timeout)


def start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([*STATION, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def recording(tmp_path: Path) -> Path:
    """A Cintiq trace: 44 pen samples over ~1 s, four proximity periods."""
    tablet = MockTablet(find_model("cintiq-22hd"), script="proximity", reports=16)
    for f in tablet.init_features:
        tablet.feature(f)
    info = tablet.info
    path = tmp_path / "cintiq.hid"
    synth.write_hid_recorder([synth.RecordedDevice(
        info.name, info.vid, info.pid, info.descriptor or b"",
        [(r.time, r.data) for r in tablet.timed_reports()], bus=info.bus)], path)
    return path


def pen_records(log: Path) -> list[dict]:
    """The pen records of a session log (a line still being written is not one yet)."""
    out = []
    for line in log.read_text().splitlines():
        try:
            rec = json.loads(line)
        except ValueError:
            continue
        if rec.get("type") == "pen":
            out.append(rec)
    return out


def test_sim_over_tcp_paints_what_a_keyed_replay_publishes(tmp_path: Path) -> None:
    """`station sim --bus tcp://… --keys K` (CURVE client) gets every sample of
    `station replay --bus @tcp://… --keys K` (CURVE server): 44 of 44, none lost."""
    keys = tmp_path / "keys"
    generate_keys(keys)
    port = free_port()
    log = tmp_path / "s.jsonl"
    sim = start("sim", "--bus", f"tcp://127.0.0.1:{port}", "--keys", str(keys),
                "--size", "32x32", "--backend", "numpy", "--log", str(log),
                "--status", "none", "--cmd", "none", "--autosave", "0")
    try:
        played = station("replay", str(recording(tmp_path)), "--bus",
                         f"@tcp://127.0.0.1:{port}", "--keys", str(keys), "--name", "cintiq",
                         "--wait-subscribers", "1", "--json")
        assert played.returncode == 0, played.stderr
        sent = json.loads(played.stdout)["samples"]
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and (not log.exists()
                                               or len(pen_records(log)) < sent):
            time.sleep(0.1)
    finally:
        code, err = finish(sim)
    assert code == 0, err
    assert sent == 44
    final = json.loads(err.split("station sim: stopped ", 1)[1].splitlines()[0])
    assert final["samples"] == 44 and final["lost_samples"] == 0
    logged = pen_records(log)
    assert len(logged) == 44 and {r["device"] for r in logged} == {"cintiq"}


def test_recorder_with_a_key_not_authorised_gets_nothing_and_the_driver_counts_it(
        tmp_path: Path) -> None:
    """Two `station record --bus tcp://…` clients: the shared client key is authorised,
    `--client-key intruder` is not (revoked). The driver binding the tcp endpoint
    publishes to the first only, logs the intruder's public key once and counts the
    refused connections in its status (`curve_rejected`); nobody crashes."""
    keys = tmp_path / "keys"
    generate_keys(keys)
    intruder = add_client_key("intruder", keys)
    (keys / "authorized" / "client-intruder.key").unlink()
    intruder_public = next(ln.split('"')[1] for ln in intruder.read_text().splitlines()
                           if ln.strip().startswith("public-key"))
    port = free_port()
    endpoint = f"tcp://127.0.0.1:{port}"
    good_out, bad_out, drv_out = (tmp_path / n for n in ("good.jsonl", "bad.jsonl",
                                                         "drv.jsonl"))
    bad = start("record", "--bus", endpoint, "--keys", str(keys), "--client-key", "intruder",
                "-o", str(bad_out))
    good = start("record", "--bus", endpoint, "--keys", str(keys), "-o", str(good_out))
    try:
        # waits (5 s at most) for two subscribers: only one can ever come
        drv = station("driver", "--device", "mock:intuos-pro-m?script=line&speed=max",
                      "--bus", "@" + endpoint, "--keys", str(keys), "--wait-subscribers", "2",
                      "--jsonl", str(drv_out), "--status-interval", "0.2")
        assert drv.returncode == 0, drv.stderr
        sent = len(pen_records(drv_out))
        # the recorder writes its log as it goes but flushes on exit: give the last
        # messages time to arrive, then stop it (its summary says what it got)
        time.sleep(1.0)
    finally:
        good_code, good_err = finish(good)
        bad_code, bad_err = finish(bad)
    assert good_code == 0 and bad_code == 0, (good_err, bad_err)
    assert sent > 50
    assert len(pen_records(good_out)) == sent and "lost on the bus 0" in good_err
    assert pen_records(bad_out) == [] and "0 samples" in bad_err
    # the refused recorder says why nothing arrives, once
    assert bad_err.count("refused this client's CURVE key") == 1, bad_err
    assert "refused this client's CURVE key" not in good_err
    warnings = [ln for ln in drv.stderr.splitlines() if "rejected a CURVE peer" in ln]
    assert len(warnings) == 1 and intruder_public in warnings[0]
    summary = json.loads(drv.stderr.strip().splitlines()[-1].split("station driver: ", 1)[1])
    assert summary["curve_rejected"] >= 1 and summary["total_samples"] == sent


def test_send_over_tcp_reaches_a_keyed_live_sim_and_a_refused_key_is_said(
        tmp_path: Path) -> None:
    """`station send --to tcp://… --keys K` drives a live `station sim --cmd @tcp://…`;
    a client key the sim does not authorise is refused at the handshake, and send says
    so at once (exit 1) instead of waiting out its timeout as if no sim listened."""
    keys = tmp_path / "keys"
    generate_keys(keys)
    add_client_key("intruder", keys)
    (keys / "authorized" / "client-intruder.key").unlink()
    port = free_port()
    log = tmp_path / "s.jsonl"
    sim = start("sim", "--bus", f"ipc://{tmp_path}/bus", "--cmd", f"@tcp://127.0.0.1:{port}",
                "--keys", str(keys), "--size", "32x32", "--backend", "numpy", "--log",
                str(log), "--status", "none", "--autosave", "0")
    try:
        sent = station("send", "brush", "size=9", "--to", f"tcp://127.0.0.1:{port}",
                       "--keys", str(keys), "--timeout", "20")
        t0 = time.monotonic()
        refused = station("send", "clear", "--to", f"tcp://127.0.0.1:{port}", "--keys",
                          str(keys), "--client-key", "intruder", "--timeout", "20")
        took = time.monotonic() - t0
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and '"brush"' not in (
                log.read_text() if log.exists() else ""):
            time.sleep(0.1)
    finally:
        code, err = finish(sim)
    assert sent.returncode == 0, sent.stderr
    assert refused.returncode == 1 and len(refused.stderr.strip().splitlines()) == 1
    assert "refused this client's CURVE key (client-intruder.key)" in refused.stderr
    assert took < 10  # not the 20 s timeout
    assert code == 0, err
    cmds = [json.loads(ln) for ln in log.read_text().splitlines() if '"cmd"' in ln]
    painted = [(c["cmd"], c["args"]) for c in cmds if c["cmd"] != "wait"]  # (the stop's)
    assert painted == [("brush", {"size": 9})]  # and no clear
    assert "rejected a CURVE peer" in err


@pytest.mark.parametrize("argv", [
    ["sim", "--bus", "tcp://127.0.0.1:9"],
    ["record", "--bus", "tcp://127.0.0.1:9", "-o", "OUT"],
    ["replay", "TRACE", "--bus", "@tcp://127.0.0.1:9"],
    ["send", "dry", "--to", "tcp://127.0.0.1:9"],
    ["kiosk", "--bus", "tcp://127.0.0.1:9", "--serve", "none"],
    ["bus", "--pub", "ipc:p", "--sub", "tcp://127.0.0.1:9"],
], ids=lambda a: a[0])
def test_a_tcp_endpoint_without_keys_is_exit_2_with_one_line(
        tmp_path: Path, argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    """No --keys and none in the (private, empty) default directory: refused before
    anything starts (no log, no output file, no window), naming the flag and the
    directory.  In this process: the refusal comes before anything is opened."""
    from station.cli import main

    argv = [str(tmp_path / "out.jsonl") if a == "OUT" else a for a in argv]
    argv = [str(recording(tmp_path)) if a == "TRACE" else a for a in argv]
    code = main(argv)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    flag = "--to" if argv[0] == "send" else "--sub" if argv[0] == "bus" else "--bus"
    assert lines[0].startswith(f"station {argv[0]}: {flag}: ")
    assert "CURVE keys" in lines[0] and os.environ["STATION_CONFIG_DIR"] in lines[0]
    assert "pass --keys DIR" in lines[0]
    assert not (tmp_path / "out.jsonl").exists()


def test_keys_without_the_client_pair_and_a_missing_client_key_are_exit_2(
        tmp_path: Path) -> None:
    keys = tmp_path / "keys"
    generate_keys(keys)
    r = station("record", "--bus", "tcp://127.0.0.1:9", "--keys", str(keys), "--client-key",
                "nobody", "-o", str(tmp_path / "o.jsonl"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "client-nobody.key_secret" in r.stderr and str(keys) in r.stderr
    # a binding endpoint needs the server's secret key: a client's copy has none
    client_only = tmp_path / "client-only"
    client_only.mkdir(mode=0o700)
    for name in ("server.key", "client.key", "client.key_secret"):
        (client_only / name).write_bytes((keys / name).read_bytes())
    r = station("sim", "--bus", "@tcp://127.0.0.1:9", "--keys", str(client_only))
    assert r.returncode == 2 and "server.key_secret" in r.stderr


def test_a_client_needs_only_the_servers_public_key(tmp_path: Path) -> None:
    """The machine a kiosk runs on holds server.key, client.key, client.key_secret:
    enough to connect (the server's secret never leaves the server)."""
    keys = tmp_path / "keys"
    generate_keys(keys)
    remote = tmp_path / "remote"
    remote.mkdir(mode=0o700)
    for name in ("server.key", "client.key", "client.key_secret"):
        (remote / name).write_bytes((keys / name).read_bytes())
    (remote / "client.key_secret").chmod(0o600)  # a secret others can read is refused
    ctx = zmq.Context()
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    pub = Publisher(endpoint, keys=keys, context=ctx)
    sub = Subscriber(endpoint, topics=("pen.",), keys=remote, context=ctx)
    try:
        assert pub.wait_for_subscribers(1, 10)
        for i in range(1, 11):
            pub.publish_pen(PenSample(t=i / 100, device="far", tool=Tool.PEN, x=0.5, y=0.5,
                                      seq=i))
        got = list(iter(lambda: sub.recv(1000), None))
        assert [m.value.seq for m in got] == list(range(1, 11))
        assert pub.curve_rejected == 0
        assert sub.stats.refused_by_peer == 0
    finally:
        sub.close()
        pub.close()
        ctx.destroy(linger=0)


def test_a_subscriber_whose_key_is_refused_counts_it_and_warns_once(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    keys = tmp_path / "keys"
    generate_keys(keys)
    add_client_key("intruder", keys)
    (keys / "authorized" / "client-intruder.key").unlink()
    ctx = zmq.Context()
    endpoint = f"tcp://127.0.0.1:{free_port()}"
    pub = Publisher(endpoint, keys=keys, context=ctx)
    sub = Subscriber(endpoint, topics=("pen.",), keys=keys, client_key="intruder",
                     context=ctx)
    try:
        deadline = time.monotonic() + 10
        while sub.stats.refused_by_peer < 1 and time.monotonic() < deadline:
            pub.publish_pen(PenSample(t=0.0, device="d", tool=Tool.PEN, x=0.5, y=0.5))
            assert sub.recv(50) is None
        for _ in range(5):  # said once, however long it stays quiet
            assert sub.recv(20) is None
        assert sub.stats.refused_by_peer == 1  # (libzmq does not retry a refused handshake)
        assert sub.stats.as_dict()["refused_by_peer"] == sub.stats.refused_by_peer
        said = [r for r in caplog.records if "refused this client's CURVE key" in r.message]
        assert len(said) == 1 and endpoint in said[0].message
        assert pub.curve_rejected >= 1 and pub.subscriptions == 0
    finally:
        sub.close()
        pub.close()
        ctx.destroy(linger=0)


def test_two_key_directories_in_one_process_each_check_their_own_clients(
        tmp_path: Path) -> None:
    """One ZAP handler per context, one ZAP domain per key directory: a client of
    directory A is refused by the endpoint bound with B's keys and counted there."""
    a, b = tmp_path / "a", tmp_path / "b"
    generate_keys(a)
    generate_keys(b)
    mixed = tmp_path / "b-to-a"  # B's client key pair, A's server public key
    mixed.mkdir(mode=0o700)
    (mixed / "server.key").write_bytes((a / "server.key").read_bytes())
    for name in ("client.key", "client.key_secret"):
        (mixed / name).write_bytes((b / name).read_bytes())
    (mixed / "client.key_secret").chmod(0o600)  # a secret others can read is refused
    ctx = zmq.Context()
    ep_a, ep_b = (f"tcp://127.0.0.1:{free_port()}" for _ in range(2))
    pub_a = Publisher(ep_a, keys=a, context=ctx)
    pub_b = Publisher(ep_b, keys=b, context=ctx)
    subs = [Subscriber(ep_a, topics=("pen.",), keys=a, context=ctx),
            Subscriber(ep_b, topics=("pen.",), keys=b, context=ctx),
            Subscriber(ep_a, topics=("pen.",), keys=mixed, context=ctx)]  # B's key at A
    try:
        assert pub_a.wait_for_subscribers(1, 10) and pub_b.wait_for_subscribers(1, 10)
        deadline = time.monotonic() + 10
        while pub_a.curve_rejected == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert pub_a.curve_rejected >= 1 and pub_b.curve_rejected == 0
        assert pub_a.subscriptions == 1
        # a subscriber that binds (a sim on @tcp://): the count is in its stats (status)
        ep_c = f"tcp://127.0.0.1:{free_port()}"
        subs.append(Subscriber("@" + ep_c, topics=("pen.",), keys=b, context=ctx))
        a_to_b = tmp_path / "a-to-b"  # A's client pair, B's server public key
        a_to_b.mkdir(mode=0o700)
        (a_to_b / "server.key").write_bytes((b / "server.key").read_bytes())
        for name in ("client.key", "client.key_secret"):
            (a_to_b / name).write_bytes((a / name).read_bytes())
        (a_to_b / "client.key_secret").chmod(0o600)
        stranger = Publisher(">" + ep_c, keys=a_to_b, context=ctx)
        try:
            assert not stranger.wait_for_subscribers(1, 1.0)
            deadline = time.monotonic() + 10
            while subs[-1].curve_rejected == 0 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert subs[-1].stats.as_dict()["curve_rejected"] >= 1
            assert subs[0].stats.as_dict()["curve_rejected"] == 0  # a connecting one
        finally:
            stranger.close()
    finally:
        for s in subs:
            s.close()
        pub_a.close()
        pub_b.close()
        ctx.destroy(linger=0)


# -- the blueprint --------------------------------------------------------------------
HEAD = '<?xml version="1.0"?>\n<station name="t" version="1">\n'


def tcp_blueprint(tmp_path: Path, keys: str | None = "keys") -> Path:
    attr = f' keys="{keys}"' if keys else ""
    body = (f'  <bus id="hub" pub="tcp://127.0.0.1:7101" sub="tcp://127.0.0.1:7102"{attr}>\n'
            '    <requires interface="pen" from="pen"/>\n'
            '    <requires interface="pen" from="trace"/>\n  </bus>\n'
            '  <driver id="pen" device="mock:intuos-pro-m?script=line"/>\n'
            '  <replay id="trace" trace="t.hid"/>\n'
            '  <sim id="sim" width="64" height="48">\n'
            '    <requires interface="pen" from="hub"/>\n  </sim>\n'
            '  <kiosk id="kiosk" serve="none">\n'
            '    <requires interface="pen" from="hub"/>\n  </kiosk>\n'
            '  <recorder id="rec" output="r.jsonl">\n'
            '    <requires interface="pen" from="hub"/>\n  </recorder>\n')
    path = tmp_path / "bp.xml"
    path.write_text(HEAD + body + "</station>\n")
    return path


def flag(argv: list[str], name: str) -> str | None:
    return argv[argv.index(name) + 1] if name in argv else None


def test_blueprint_gives_tcp_consumers_and_replay_the_bus_keys(tmp_path: Path) -> None:
    plan = resolve(load(str(tcp_blueprint(tmp_path))), Path("/r"), tmp_path)
    keys = str(tmp_path / "keys")  # relative to the blueprint
    p = {q.id: q for q in plan.processes}
    assert p["hub"].argv == ["bus", "--pub", "tcp://127.0.0.1:7101", "--sub",
                             "tcp://127.0.0.1:7102", "--keys", keys]
    for source in ("pen", "trace"):
        assert flag(p[source].argv, "--bus") == ">tcp://127.0.0.1:7101"
        assert flag(p[source].argv, "--keys") == keys
    assert p["trace"].argv[0] == "replay"
    for consumer in ("sim", "kiosk", "rec"):
        assert flag(p[consumer].argv, "--bus") == "tcp://127.0.0.1:7102"
        assert flag(p[consumer].argv, "--keys") == keys
    recover = p["sim"].recover_argv
    assert recover is not None and flag(recover, "--keys") == keys
    assert flag(recover, "--bus") == "tcp://127.0.0.1:7102"
    # every argv parses: the flags exist on the commands they are given to
    parser = build_parser()
    for q in plan.processes:
        assert parser.parse_args(q.argv).func is not None


def test_blueprint_without_bus_keys_uses_the_default_directory(tmp_path: Path) -> None:
    plan = resolve(load(str(tcp_blueprint(tmp_path, keys=None))), Path("/r"), tmp_path)
    for q in plan.processes:
        assert "--keys" not in q.argv, q.id


def test_blueprint_ipc_bus_passes_no_keys(tmp_path: Path) -> None:
    """keys= on an ipc bus: nothing to authenticate, no --keys anywhere but the bus."""
    text = tcp_blueprint(tmp_path).read_text().replace('pub="tcp://127.0.0.1:7101" '
                                                       'sub="tcp://127.0.0.1:7102"', "")
    (tmp_path / "bp.xml").write_text(text)
    plan = resolve(load(str(tmp_path / "bp.xml")), Path("/r"), tmp_path)
    assert [q.id for q in plan.processes if "--keys" in q.argv] == ["hub"]


def test_blueprint_still_refuses_what_cannot_work(tmp_path: Path) -> None:
    """Two tcp endpoints clash by port whatever the keys."""
    text = tcp_blueprint(tmp_path).read_text().replace("7102", "7101")
    (tmp_path / "bp.xml").write_text(text)
    with pytest.raises(BlueprintError, match="7101"):
        resolve(load(str(tmp_path / "bp.xml")), Path("/r"), tmp_path)


def test_systemd_units_refuse_a_tcp_bus_whose_keys_are_hidden(tmp_path: Path) -> None:
    """The units run with ProtectHome=yes: the default ~/.config/station/keys is not there
    for them, so a tcp <bus> needs keys= outside the home directories."""
    with pytest.raises(BlueprintError, match=r"bp.xml:3: .*needs keys=DIR"):
        units(load(str(tcp_blueprint(tmp_path, keys=None))))
    with pytest.raises(BlueprintError, match="hidden from the units"):
        units(load(str(tcp_blueprint(tmp_path, keys="/home/station/keys"))))
    made = units(load(str(tcp_blueprint(tmp_path))))
    text = made["station-t.service"]
    assert "ProtectHome=yes" in text and " run /etc/station/t.xml " in text


def test_doctor_checks_the_keys_of_a_tcp_bus(tmp_path: Path) -> None:
    def keys_checks() -> list[doctor.Check]:
        plan = resolve(load(str(tcp_blueprint(tmp_path))), Path("/r"), tmp_path)
        return doctor.check_keys(plan)

    (missing,) = keys_checks()
    assert missing.status == "fail" and str(tmp_path / "keys") in missing.detail
    assert "station keys --dir" in missing.fix
    generate_keys(tmp_path / "keys")
    (ok,) = keys_checks()
    assert ok.status == "ok" and "1 authorised client key(s)" in ok.detail
    (tmp_path / "keys" / "authorized" / "client.key").unlink()
    (nobody,) = keys_checks()
    assert nobody.status == "fail" and "every client is refused" in nobody.detail


def test_kiosk_on_a_tcp_bus_with_keys_paints_the_pen(tmp_path: Path) -> None:
    """The kiosk on another machine than its drivers: `station bus` serves the pens on a
    tcp sub side (CURVE server), `station kiosk --bus tcp://… --keys K` connects with
    the client pair only (no server secret on its side) and takes every sample."""
    keys = tmp_path / "keys"
    generate_keys(keys)
    remote = tmp_path / "remote"  # what the kiosk's machine holds
    remote.mkdir(mode=0o700)
    for name in ("server.key", "client.key", "client.key_secret"):
        (remote / name).write_bytes((keys / name).read_bytes())
    (remote / "client.key_secret").chmod(0o600)  # a secret others can read is refused
    port = free_port()
    with xvfb() as display:
        bus = kstation("bus", "--pub", "ipc:pub", "--sub", f"tcp://127.0.0.1:{port}",
                       "--keys", str(keys))
        kiosk = kstation("kiosk", "--windowed", "--bus", f"tcp://127.0.0.1:{port}",
                         "--keys", str(remote), "--gallery", str(tmp_path / "gallery"),
                         "--serve", "none", "--no-vsync", "--size", "64x48",
                         "--status", "@ipc:kiosk-status", "--cmd", "none",
                         "--backend", "numpy", display=display)
        status = Subscriber("ipc:kiosk-status", topics=("status",))
        pub = Publisher(">ipc:pub")
        last: dict = {}
        try:
            def wait(cond: Callable[[dict], bool], timeout: float) -> bool:
                deadline = time.monotonic() + timeout
                while time.monotonic() < deadline and kiosk.poll() is None:
                    m = status.recv(100)
                    if m is not None and m.value.get("process") == "kiosk":
                        last.update(m.value)
                        if cond(m.value):
                            return True
                    pub.poll_subscriptions()
                return False

            assert wait(lambda s: s.get("frames", 0) > 2, 90), last
            assert pub.wait_for_subscribers(1, 30)
            x0, y0 = SCREEN[0] * 0.6, SCREEN[1] * 0.5  # on the canvas, right of the panel
            for i in range(60):
                pub.publish_pen(PenSample(
                    t=0.005 * (i + 1), device="far", tool=Tool.PEN,
                    x=(x0 + 2 * i) / SCREEN[0], y=y0 / SCREEN[1], pressure=0.6,
                    touching=0 < i < 59, seq=i + 1, t_mono=time.monotonic()))
                time.sleep(0.005)
            assert wait(lambda s: s.get("samples", 0) >= 60, 30), last
        finally:
            pub.close()
            status.close()
            code, err = finish(kiosk, 60)
            finish(bus)
    assert code == 0, err
    # all 60 of the bus's samples (the kiosk may count one of its own beside them: a
    # synthesised lift when the far pen falls silent, or the window's mouse)
    assert last["samples"] in (60, 61) and last["bus"]["lost"] == 0, last
    assert last["bus"]["curve_rejected"] == 0
