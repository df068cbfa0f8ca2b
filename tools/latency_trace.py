"""Where the kiosk's latency tail comes from (issue 26 item 3): ``station bench latency``'s
run with every frame, lock wait and lock hold, step part and garbage collection traced.

Runs :func:`station.bench.latency.measure` in this process with the session's lock
replaced by one that records, per thread, how long it waited for the lock and how long
it held it, and with time marks around the frame, the step's kernel and the step's parts
that run under the lock (taking and adding the stamps, checkpoints, beads).  Prints the
bench's figures, then, for the frames that showed the slowest paint, what overlapped the
wait of that paint: the window's waits for the lock, the simulation thread's holds and
what it did meanwhile, the kernel, collections.

    .venv/bin/python tools/latency_trace.py [--size 1920x1080] [--seconds 10] [--top 8]
        [--old-nice]

``--old-nice``: the simulation thread niced as a whole, as before ``station.kiosk.niced``
(its kernel and its locked parts), for an A/B in one tree.  Write ``uptime`` beside
every figure: on a shared machine they move with the load.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import threading
import time
from collections.abc import Callable
from typing import Any

from station.bench import latency as bench
from station.kiosk import loop, niced
from station.kiosk import session as session_mod
from station.kiosk.app import KioskApp
from station.sim import journal as journal_mod
from station.sim import live_bus as live_mod
from station.sim import player as player_mod

pc = time.perf_counter
EVENTS: list[tuple[str, str, float, float, Any]] = []  # kind, thread, start, end, extra


def _thread() -> str:
    return threading.current_thread().name


class TracedLock:
    """An ``RLock`` that records waits over 0.2 ms and holds over 0.5 ms per thread."""

    def __init__(self) -> None:
        self._lock = threading.RLock()
        self._since: dict[str, list[float]] = {}

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        t0 = pc()
        ok = self._lock.acquire(blocking, timeout)
        t1 = pc()
        if ok:
            if t1 - t0 > 2e-4:
                EVENTS.append(("wait", _thread(), t0, t1, None))
            self._since.setdefault(_thread(), []).append(t1)
        return ok

    def release(self) -> None:
        t0 = self._since[_thread()].pop()
        self._lock.release()
        if pc() - t0 > 5e-4:
            EVENTS.append(("hold", _thread(), t0, pc(), None))

    def __enter__(self) -> bool:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()

    def _is_owned(self) -> bool:
        return bool(self._lock._is_owned())  # type: ignore[attr-defined]

    def _release_save(self) -> Any:
        t0 = self._since[_thread()].pop()
        if pc() - t0 > 5e-4:
            EVENTS.append(("hold", _thread(), t0, pc(), None))
        return self._lock._release_save()  # type: ignore[attr-defined]

    def _acquire_restore(self, state: Any) -> None:
        self._lock._acquire_restore(state)  # type: ignore[attr-defined]
        self._since.setdefault(_thread(), []).append(pc())


def _timed(owner: Any, name: str) -> None:
    real: Callable[..., Any] = getattr(owner, name)

    def wrapper(*a: Any, **kw: Any) -> Any:
        t0 = pc()
        try:
            return real(*a, **kw)
        finally:
            if pc() - t0 > 2e-4:
                EVENTS.append((name, _thread(), t0, pc(), None))

    setattr(owner, name, wrapper)


def install(old_nice: bool) -> None:
    real_init = session_mod.KioskSession.__init__

    def init(self: session_mod.KioskSession, *a: Any, **kw: Any) -> None:
        real_init(self, *a, **kw)
        self.lock = threading.Condition(TracedLock())  # type: ignore[arg-type]

    session_mod.KioskSession.__init__ = init  # type: ignore[method-assign]
    real_frame = KioskApp.frame

    def frame(self: KioskApp, dt: float) -> None:
        t0, c0 = pc(), time.thread_time()
        real_frame(self, dt)
        EVENTS.append(("pass", "MainThread", t0, pc(), time.thread_time() - c0))

    KioskApp.frame = frame  # type: ignore[method-assign]
    real_shown = loop.record_shown

    def record_shown(app: KioskApp, shown: float, times: Any, n_early: int) -> None:
        lag = [shown - t for t in app.session.awaiting_paint]
        EVENTS.append(("shown", "MainThread", times.start, times.shown, max(lag, default=0.0)))
        real_shown(app, shown, times, n_early)

    loop.record_shown = record_shown
    for owner, name in ((player_mod.SessionPlayer, "take_step"),
                        (player_mod.SessionPlayer, "apply_step"),
                        (journal_mod.SessionJournal, "flush"),
                        (session_mod.KioskSession, "finish_mid_step"),
                        (session_mod.KioskSession, "materialize_checkpoints"),
                        (live_mod.LiveSim, "maybe_autosave")):
        _timed(owner, name)

    def on_gc(phase: str, info: dict[str, Any]) -> None:
        if phase == "start":
            on_gc.t0 = pc()  # type: ignore[attr-defined]
        else:
            EVENTS.append(("gc", _thread(), on_gc.t0, pc(), None))  # type: ignore[attr-defined]

    gc.callbacks.append(on_gc)
    if old_nice:  # the whole simulation thread niced (kernel and lock holder alike)
        real_runner = niced.NicedRunner.__init__

        def runner(self: niced.NicedRunner, nice: int, threads: int,
                   name: str = "kiosk-kernel") -> None:
            real_runner(self, 0, threads, name)

        niced.NicedRunner.__init__ = runner  # type: ignore[method-assign]
        real_work = session_mod.KioskSession._work

        def work(self: session_mod.KioskSession) -> None:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(),
                           os.getpriority(os.PRIO_PROCESS, 0) + self._nice)
            real_work(self)

        session_mod.KioskSession._work = work  # type: ignore[method-assign]


def _overlap(kind: str, thread: str | None, a: float, b: float, since: float) -> float:
    return sum(max(0.0, min(b, e[3]) - max(a, e[2])) for e in EVENTS
               if e[0] == kind and e[2] >= since - 1 and (thread is None or e[1] == thread))


def report(result: dict[str, Any], top: int) -> dict[str, Any]:
    n = result["frames"]["frames"]
    shown = [e for e in EVENTS if e[0] == "shown"][-n:]
    since = shown[0][2] if shown else 0.0
    slow = []
    for e in sorted(shown, key=lambda e: -e[4])[:top]:
        a, b = e[3] - e[4], e[3]
        inside = sorted({x[0] for x in EVENTS if x[1] == "kiosk-sim" and x[0] not in (
            "hold", "wait", "gc") and x[3] > a and x[2] < b})
        slow.append({"latency_ms": round(1000 * e[4], 1),
                     "window_waited_for_lock_ms": round(1000 * _overlap(
                         "wait", "MainThread", a, b, since), 1),
                     "sim_thread_held_lock_ms": round(1000 * _overlap(
                         "hold", "kiosk-sim", a, b, since), 1),
                     "kernel_ms": round(1000 * _overlap("apply_step", None, a, b, since), 1),
                     "gc_ms": round(1000 * _overlap("gc", None, a, b, since), 1),
                     "sim_thread_did": inside})
    totals: dict[str, dict[str, float]] = {}
    for kind, thread, t0, t1, _ in EVENTS:
        if t0 >= since and kind != "shown":
            row = totals.setdefault(f"{kind}@{thread}", {"n": 0, "total_ms": 0.0,
                                                          "max_ms": 0.0})
            row["n"] += 1
            row["total_ms"] = round(row["total_ms"] + 1000 * (t1 - t0), 1)
            row["max_ms"] = round(max(row["max_ms"], 1000 * (t1 - t0)), 1)
    return {"slowest_paint": slow, "per_thread": totals}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--window", default="1920x1080")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--top", type=int, default=8)
    ap.add_argument("--old-nice", action="store_true")
    args = ap.parse_args()
    install(args.old_nice)
    w, h = (int(v) for v in args.size.split("x"))
    window = tuple(int(v) for v in args.window.split("x"))
    xvfb = None
    if not os.environ.get("DISPLAY"):
        xvfb, os.environ["DISPLAY"] = bench._start_xvfb((window[0], window[1]))
    try:
        result = bench.measure(w, h, "cpu", args.seconds, 200, "intuos-pro-m",
                               window=(window[0], window[1]), wet=True)
    finally:
        if xvfb is not None:
            xvfb.terminate()
            xvfb.wait(10)
    out = {"load_avg": result["load_avg"], "old_nice": args.old_nice,
           "latency": {k: result["latency"][k] for k in ("p50_ms", "p99_ms", "max_ms")},
           "fps": result["frames"]["fps"],
           "sim_steps_per_s": result["frames"]["sim_steps_per_s"],
           "window_lock_waits": result["frames"].get("window_lock_waits"),
           **report(result, args.top)}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
