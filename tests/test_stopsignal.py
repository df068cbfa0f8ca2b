"""The stop flag that signal handlers raise (station/stopsignal.py)."""

from __future__ import annotations

import ast
import signal
import threading
import time
from pathlib import Path

from station.stopsignal import StopSignal, stop_on_signals

ROOT = Path(__file__).resolve().parents[1]


def test_a_signal_ends_a_long_wait_at_once() -> None:
    stop = StopSignal()
    with stop_on_signals(stop, (signal.SIGALRM,)):
        signal.setitimer(signal.ITIMER_REAL, 0.05)
        t0 = time.monotonic()
        assert stop.wait(20.0) is True
        waited = time.monotonic() - t0
    assert 0.03 < waited < 2.0, waited
    assert stop.is_set() and stop.wait(0) is True
    assert signal.getsignal(signal.SIGALRM) is not stop.handler  # the old handler is back


def test_wait_times_out_unset_and_another_thread_can_set_it() -> None:
    stop = StopSignal()
    t0 = time.monotonic()
    assert stop.wait(0.1) is False
    assert time.monotonic() - t0 >= 0.09
    threading.Timer(0.05, stop.set).start()
    assert stop.wait(20.0) is True
    stop.set()  # a second set is harmless
    stop.close()
    assert stop.is_set()


def test_a_storm_of_signals_during_short_waits_never_hangs() -> None:
    """The pattern that hung CI's driver: the handler raising the stop while the main
    thread is inside ``wait``.  With a lock-taking flag this deadlocks sooner or later."""
    stop = StopSignal()
    hits = 0

    def handler(signum: int, frame: object) -> None:
        nonlocal hits
        hits += 1
        if hits >= 200:
            stop.set()

    old = signal.signal(signal.SIGALRM, handler)
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.0005, 0.0005)
        deadline = time.monotonic() + 30
        while not stop.is_set() and time.monotonic() < deadline:
            stop.wait(0.0003)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    assert stop.is_set() and hits >= 200


def test_no_signal_handler_takes_a_lock() -> None:
    """Every SIGINT/SIGTERM handler in the tree is a StopSignal's or sets a plain flag:
    none calls ``.set()`` on something that may be a ``threading.Event``."""
    offenders = []
    for path in sorted((ROOT / "station").rglob("*.py")) + sorted((ROOT / "drivers").rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr == "signal" and len(node.args) == 2):
                continue
            target = node.args[1]
            if isinstance(target, ast.Lambda) and "set()" in ast.unparse(target.body):
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert offenders == []
