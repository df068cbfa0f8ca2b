"""`station send` answers: the taking process says what it did or why not (issue 24.4)."""

from __future__ import annotations

import json
import os
import socket
import threading
import time
from pathlib import Path

import pytest
import zmq

from station.answer import ReadKeys, ReplyRequest, parse_request
from station.bus import runtime_dir
from station.cli import main
from station.events import Command
from station.sim.live import LiveConfig
from station.sim.live_bus import LiveSim


def _sim(tmp_path: Path, cmd: str | None = None) -> tuple[LiveSim, threading.Thread]:
    cfg = LiveConfig(bus=f"ipc://{tmp_path}/bus", width=16, height=16, backend="numpy",
                     log_path=str(tmp_path / "s.jsonl"), status="none", autosave=0.0, cmd=cmd)
    sim = LiveSim(cfg)
    th = threading.Thread(target=sim.run, daemon=True)
    th.start()
    return sim, th


def _wait_refused(port: int, deadline_s: float) -> bool:
    """Until a tcp connect to ``port`` is refused (True) or ``deadline_s`` passes."""
    end = time.monotonic() + deadline_s
    while time.monotonic() < end:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
        except OSError:
            return True
        time.sleep(0.05)
    return False


def _send(capsys: pytest.CaptureFixture[str], *words: str) -> tuple[int, str, str]:
    code = main(["send", *words, "--timeout", "20"])
    out, err = capsys.readouterr()
    return code, out, err


def test_send_gets_an_answer_or_a_reason(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    sim, th = _sim(tmp_path)
    try:
        code, out, err = _send(capsys, "brush", "size=10", 'pigment={"Burnt Umber": 0.7}')
        assert code == 0, err
        assert out.startswith("sim ") and "(session s)" in out and "brush set" in out
        assert "size 10" in out
        code, out, err = _send(capsys, "--json", "profile", "name=ink")
        answer = json.loads(out)
        assert code == 0 and answer["ok"] is True and answer["process"] == "sim"
        assert answer["session"] == "s" and answer["cmd"] == "profile"
        for words, text in ((["brush", "colour=red", "sizee=3"], "'colour', 'sizee'"),
                            (["hairdryer", '{"seconds": 1e9}'], "hairdryer seconds"),
                            (["brush", 'pigment={"Unobtainium": 1}'], "Unobtainium"),
                            (["fly"], "command 'fly' is unknown"),
                            (["stop", "now=1"], "'now'")):
            code, out, err = _send(capsys, *words)
            lines = err.strip().splitlines()
            assert code == 2 and len(lines) == 1, (words, err)
            assert "refused by sim" in lines[0] and text in lines[0], (words, err)
        # `--to kiosk` does not reach a sim (a kiosk has an endpoint of its own) ...
        code, _, err = main(["send", "stop", "--to", "kiosk", "--timeout", "0.3"]), "", \
            capsys.readouterr().err
        assert code == 1 and "no station kiosk listens" in err
        assert sim.counters.commands == 2 and sim.counters.bad_commands == 5
        code, out, err = _send(capsys, "stop")
        assert code == 0 and "stopping" in out
        th.join(30)
        assert not th.is_alive()
    finally:
        sim.stop_requested = True
        th.join(30)
    cmds = [json.loads(ln) for ln in (tmp_path / "s.jsonl").read_text().splitlines()[1:]]
    assert [c["cmd"] for c in cmds if c["type"] == "cmd"] == ["brush", "profile", "wait"]
    assert all("reply" not in c for c in cmds)  # the answer channel is never logged


def test_a_process_refuses_a_command_meant_for_another_kind(tmp_path: Path) -> None:
    """What `station send --to kiosk` puts on the wire, reaching a sim (an operator's
    --cmd pointed both at one socket): refused, named, and the sim keeps running."""
    cfg = LiveConfig(bus=f"ipc://{tmp_path}/bus", width=16, height=16, backend="numpy",
                     log_path=str(tmp_path / "s.jsonl"), status="none", autosave=0.0,
                     cmd="none")
    sim = LiveSim(cfg)
    inbox_path = runtime_dir() / "reply-1-ab"
    inbox = zmq.Context.instance().socket(zmq.PULL)
    inbox.bind(f"ipc://{inbox_path}")
    try:
        req = ReplyRequest(f"ipc://{inbox_path}", "ab", "kiosk").as_record()
        assert sim.feed_command(Command(t=0.0, cmd="stop", reply=req)) is False
        assert not sim.stop_requested
        assert inbox.poll(10_000)
        answer = json.loads(inbox.recv())
        assert answer == {"id": "ab", "ok": False, "process": "sim", "pid": os.getpid(),
                          "session": "s", "cmd": "stop",
                          "error": answer["error"]}
        assert "this is a sim, not a kiosk" in answer["error"]
        # without an answer request the old fire-and-forget command still works
        assert sim.feed_command(Command(t=0.0, cmd="stop")) is True and sim.stop_requested
    finally:
        inbox.close(linger=0)
        sim.shutdown()


def test_reply_requests_only_reach_the_runtime_directory(tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    ok = parse_request({"to": f"ipc://{run}/reply-1-ab", "id": "ab", "expect": "sim"}, run)
    assert ok is not None and ok.expect == "sim"
    for bad in ({"to": "tcp://10.0.0.1:80", "id": "ab"},
                {"to": f"ipc://{tmp_path}/reply-1-ab", "id": "ab"},
                {"to": f"ipc://{run}/../reply-1-ab", "id": "ab"},
                {"to": f"ipc://{run}/bus", "id": "ab"},
                {"to": f"ipc://{run}/reply-1-ab", "id": "x" * 65},
                "ipc://x"):
        assert parse_request(bad, run) is None, bad


def test_read_keys_names_what_nothing_read() -> None:
    args = ReadKeys({"size": 3, "sizee": 4, "pigment": {"a": 1}})
    args.get("size")
    assert "pigment" in args
    assert args.unread() == ["sizee"]
    dict(args)
    assert args.unread() == []


def test_bench_send_prints_its_figures(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "send", "--calls", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["calls"] == 1 and out["target_ms"] == 300.0
    assert out["startup_ms"]["median"] > 0 and out["round_trip_ms"] < out["process_ms"]["median"]


def test_send_over_tcp_with_curve_keys_gets_the_same_answers(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A sim whose command endpoint is tcp (CURVE, the bus's keys) answers over the
    connection the command came on: who answered, exit 2 for a refusal, exit 1 for
    nobody; the answer of one sender never reaches another's stdout."""
    from station.bus import generate_keys

    keys = tmp_path / "keys"
    generate_keys(keys)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = int(s.getsockname()[1])
    cfg = LiveConfig(bus=f"ipc://{tmp_path}/bus", width=16, height=16, backend="numpy",
                     log_path=str(tmp_path / "s.jsonl"), status="none", autosave=0.0,
                     cmd=f"@tcp://127.0.0.1:{port}", keys=keys)
    sim = LiveSim(cfg)
    th = threading.Thread(target=sim.run, daemon=True)
    th.start()
    to = ["--to", f"tcp://127.0.0.1:{port}", "--keys", str(keys)]
    try:
        code, out, err = _send(capsys, *to, "brush", "size=10")
        assert code == 0, err
        assert out.startswith(f"sim {os.getpid()} (session s): brush set (size 10)"), out
        code, out, err = _send(capsys, *to, "--json", "profile", "name=ink")
        answer = json.loads(out)
        assert code == 0 and answer["ok"] is True and answer["session"] == "s"
        for words, text in ((["brush", "sizee=3"], "'sizee'"),
                            (["hairdryer", '{"seconds": 1e9}'], "hairdryer seconds"),
                            (["fly"], "command 'fly' is unknown")):
            code, out, err = _send(capsys, *to, *words)
            lines = err.strip().splitlines()
            assert code == 2 and len(lines) == 1 and out == "", (words, err)
            assert f"refused by sim {os.getpid()} (session s)" in lines[0], lines
            assert text in lines[0], lines
    finally:
        sim.stop_requested = True
        th.join(30)
    assert sim.counters.commands == 2 and sim.counters.bad_commands == 3
    assert sim.answerer.sent == 5 and sim.answerer.failed == 0
    assert sim.status()["cmd_endpoint"]["received"] == 5
    assert not th.is_alive()
    # nobody on the port now (a closed zmq socket lets go of its listener in its io
    # thread, which a loaded machine may run late): exit 1 with one line, within the timeout
    assert _wait_refused(port, 60.0)
    code = main(["send", *to, "dry", "--timeout", "0.5"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "no station process listens" in err[0], err


def test_the_kiosk_answers_over_its_tcp_command_endpoint_too(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The kiosk's own command loop (station.kiosk.pen_input.commands) lends its tcp endpoint's
    answer channel while it handles what came there: the window itself is not needed
    (a stand-in session passes the commands to a live sim, as the kiosk's does)."""
    from types import SimpleNamespace

    from station.bus import Subscriber, generate_keys
    from station.kiosk import pen_input

    keys = tmp_path / "keys"
    generate_keys(keys)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = int(s.getsockname()[1])
    sim = LiveSim(LiveConfig(bus=f"ipc://{tmp_path}/bus", width=16, height=16,
                             backend="numpy", log_path=str(tmp_path / "s.jsonl"),
                             status="none", autosave=0.0, cmd="none"))
    sim.answer_as("kiosk")
    cmd_sub = Subscriber(f"@tcp://127.0.0.1:{port}", topics=("cmd",), keys=keys,
                         answers=True)
    app = SimpleNamespace(cmd_sub=cmd_sub, session=SimpleNamespace(sim=sim, handle=sim.handle))
    done = threading.Event()

    def loop() -> None:
        while not done.is_set():
            pen_input.commands(app)  # type: ignore[arg-type]
            done.wait(0.01)

    th = threading.Thread(target=loop, daemon=True)
    th.start()
    try:
        code, out, err = _send(capsys, "--to", f"tcp://127.0.0.1:{port}", "--keys",
                               str(keys), "brush", "size=7")
    finally:
        done.set()
        th.join(30)
        cmd_sub.close()
        sim.shutdown()
    assert code == 0 and out.startswith(f"kiosk {os.getpid()} (session s): brush set"), (
        out, err)
    assert sim.answerer.upstream is None  # lent only while the loop handled them


def test_with_nobody_listening_a_bad_key_is_still_refused(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """`station send brush sizee=3` with no sim is the same bad input (exit 2, naming
    the key) as with one; a good command with nobody there is exit 1."""
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    for words, text in ((["brush", "sizee=3"], "brush takes no key 'sizee'"),
                        (["stop", "now=1"], "stop takes no key 'now'"),
                        (["dry", "hard=1"], "dry takes no key 'hard'")):
        code = main(["send", *words, "--timeout", "0.3"])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and text in err[0], (words, err)
    assert main(["send", "brush", "size=3", "--timeout", "0.3"]) == 1
    assert "no station sim listens" in capsys.readouterr().err
