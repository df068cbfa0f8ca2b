"""``station run``: every component its own process, supervised.

Start: buses, then consumers, then pen sources (:func:`~station.blueprint.plan.resolve`
decides the order); a component with a status endpoint counts as up once its
first status arrives.  A component that exits on its own is restarted per its
``restart=`` policy with exponential back-off (``restart-delay`` doubling up to
:data:`MAX_BACKOFF_S`, reset after :data:`STABLE_S` of running), each restart
logged; exit code 2 (bad input) is never retried.  A sim that crashed comes back
with ``--recover LOG``: autosave + the log since, so its painting continues.
SIGTERM/SIGINT (or ``--duration``, or ``--once`` when the sources are done): the
``stopping`` rules run, then the processes get SIGTERM in reverse start order,
each awaited (the sim saves state, PNG and log on SIGTERM) before the next.

The supervisor writes ``RUN/supervisor.json`` (pids, states, restarts) whenever
something changes, and each child's output to ``RUN/logs/ID.log`` and, prefixed
with ``[ID]``, to its own stderr.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from station import sdnotify
from station.blueprint.model import SupervisorError
from station.blueprint.plan import MIN_RESTART_DELAY_S, Plan, Process
from station.blueprint.rules import Fired, RuleEngine
from station.bus import Publisher, Subscriber
from station.canvas.profiles import get_profile
from station.canvas.state import CanvasState
from station.events import Command
from station.render.km import render_state
from station.sim.paint import write_image
from station.stopsignal import StopSignal

MAX_BACKOFF_S = 30.0
STABLE_S = 10.0  # a component that ran this long starts its back-off afresh
READY_TIMEOUT_S = 60.0
STOP_TIMEOUT_S = 30.0
DRAIN_S = 1.0  # --once: painters quiet this long after the sources finished
FRESH_STATUS_S = 1.0  # a painter publishes status twice a second while it runs
SAVE_TIMEOUT_S = 15.0
EXIT_BAD_INPUT = 2


@dataclass
class Child:
    """One supervised component and what happened to it."""

    proc: Process
    popen: subprocess.Popen[bytes] | None = None
    state: str = "pending"  # pending running backoff finished failed stopped
    starts: int = 0
    restarts: int = 0
    backoff_n: int = 0
    started_at: float = 0.0
    next_start: float = 0.0
    exit: int | None = None
    reader: threading.Thread | None = None
    status: dict[str, Any] = field(default_factory=dict)
    status_at: float = 0.0


def _signal_name(code: int) -> str:
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"signal {-code} ({signal.Signals(-code).name})"
        return f"signal {-code}"
    return f"exit {code}"


def prepare_run_dir(run_dir: Path) -> Path:
    """Create the run directory 0700, or accept an existing one only if it is ours and
    closed to others (a path the user named is never chmod-ed)."""
    try:
        run_dir.mkdir(mode=0o700, parents=True, exist_ok=True)
        st = run_dir.stat()
    except OSError as exc:
        raise SupervisorError(f"{run_dir}: cannot create the run directory "
                              f"({exc.strerror})") from None
    if st.st_uid != os.getuid():
        raise SupervisorError(f"{run_dir}: the run directory belongs to another user")
    if st.st_mode & 0o077:
        raise SupervisorError(f"{run_dir}: the run directory is open to others "
                              f"(mode {st.st_mode & 0o777:o}); use a private one")
    (run_dir / "logs").mkdir(mode=0o700, exist_ok=True)
    return run_dir


def running_pid(run_dir: Path) -> int | None:
    """The pid of a supervisor already running on this run directory, if any."""
    try:
        pid = int(json.loads((run_dir / "supervisor.json").read_text())["pid"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if pid == os.getpid():
        return None
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return None
    except PermissionError:
        return pid
    return pid


def child_env(plan: Plan) -> dict[str, str]:
    env = sdnotify.child_environ(dict(os.environ))  # only the supervisor tells systemd
    env["STATION_RUNTIME_DIR"] = str(plan.run_dir)
    env["PYTHONUNBUFFERED"] = "1"
    return env


def argv_for(proc: Process) -> list[str]:
    """The command line of this start: a sim whose log is there recovers from it."""
    if proc.recover_argv is not None and proc.log is not None and proc.log.exists():
        return proc.recover_argv
    return proc.argv


class Supervisor:
    """Runs a :class:`Plan` (see the module docstring)."""

    def __init__(self, plan: Plan, once: bool = False, duration: float | None = None,
                 out: IO[str] | None = None) -> None:
        self.plan = plan
        self.once = once
        self.duration = duration
        self.out = out or sys.stderr
        self.children = [Child(p) for p in plan.processes]
        self.by_id = {c.proc.id: c for c in self.children}
        self.stop_requested = StopSignal()
        self.stopping = False
        self.env = child_env(plan)
        painters = [p.id for p in plan.processes if p.kind in ("sim", "kiosk")]
        self.rules = RuleEngine(plan.blueprint.rules, painters)
        self.subs: dict[str, Subscriber] = {}
        self.pubs: dict[str, Publisher] = {}
        self.saved: list[Path] = []
        self.messages: list[str] = []
        self._lock = threading.Lock()
        self._sources_done_at: float | None = None
        self._drain: dict[str, tuple[object, float]] = {}  # id -> (samples, since)

    # -- logging and state ------------------------------------------------------
    def log(self, text: str) -> None:
        with self._lock:
            self.out.write(f"station run: {text}\n")
            self.out.flush()

    def write_state(self) -> None:
        state = {"name": self.plan.blueprint.name, "file": self.plan.blueprint.file,
                 "pid": os.getpid(), "run_dir": str(self.plan.run_dir),
                 "stopping": self.stopping,
                 "components": {c.proc.id: {
                     "kind": c.proc.kind, "state": c.state,
                     "pid": c.popen.pid if c.popen is not None and c.state == "running"
                     else None,
                     "starts": c.starts, "restarts": c.restarts, "exit": c.exit,
                     "log": str(c.proc.log) if c.proc.log else None}
                     for c in self.children},
                 "saved_to_gallery": [str(p) for p in self.saved],
                 "messages": self.messages}
        path = self.plan.run_dir / "supervisor.json"
        tmp = path.with_name(f".supervisor.json.{os.getpid()}")
        tmp.write_text(json.dumps(state, indent=1) + "\n", encoding="utf-8")
        os.replace(tmp, path)

    # -- processes --------------------------------------------------------------
    def _start(self, child: Child) -> None:
        proc = child.proc
        for path in proc.outputs:
            target = path if proc.kind == "kiosk" else path.parent
            target.mkdir(parents=True, exist_ok=True)
        argv = argv_for(proc)
        cmd = [sys.executable, "-m", "station", *argv]
        log_path = self.plan.run_dir / "logs" / f"{proc.id}.log"
        try:
            child.popen = subprocess.Popen(cmd, stdin=subprocess.DEVNULL,
                                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                           env=self.env, cwd=self.plan.workdir,
                                           start_new_session=True)
        except OSError as exc:
            raise SupervisorError(f"cannot start {proc.id}: {exc}") from None
        child.state, child.starts, child.started_at = "running", child.starts + 1, time.monotonic()
        child.exit = None
        child.reader = threading.Thread(target=self._pump, args=(proc.id, child.popen, log_path),
                                        daemon=True)
        child.reader.start()
        recovering = " (recovering its painting)" if argv is proc.recover_argv else ""
        self.log(f"{proc.id} started (pid {child.popen.pid}){recovering}")
        self.write_state()

    def _pump(self, ident: str, popen: subprocess.Popen[bytes], log_path: Path) -> None:
        assert popen.stdout is not None
        with open(log_path, "ab") as fh:
            for raw in popen.stdout:
                fh.write(raw)
                fh.flush()
                line = raw.decode("utf-8", "replace").rstrip("\n")
                with self._lock:
                    self.out.write(f"[{ident}] {line}\n")
                    self.out.flush()

    def _wait_ready(self, child: Child) -> None:
        """Until the first status (a component with a status endpoint), or it exits."""
        if child.proc.status is None:
            return
        deadline = time.monotonic() + READY_TIMEOUT_S
        while time.monotonic() < deadline and not self.stop_requested.is_set():
            self._read_status(child.proc.id, 100)
            if child.status_at:
                return
            if child.popen is not None and child.popen.poll() is not None:
                return
        if not child.status_at:
            self.log(f"{child.proc.id}: no status within {READY_TIMEOUT_S:g} s; going on")

    def _on_exit(self, child: Child, now: float) -> None:
        assert child.popen is not None
        code = child.popen.returncode
        child.exit = code
        if child.reader is not None:
            child.reader.join(timeout=2.0)
        proc = child.proc
        ran = now - child.started_at
        if self.stopping:
            child.state = "stopped"
        elif code == 0 and proc.restart != "always":
            child.state = "finished"
            self.log(f"{proc.id} finished ({_signal_name(code)}) after {ran:.1f} s")
        elif code == EXIT_BAD_INPUT:
            child.state = "failed"
            self.log(f"{proc.id} refused its input ({_signal_name(code)}); not restarted")
        elif proc.restart == "no":
            child.state = "failed"
            self.log(f"{proc.id} died ({_signal_name(code)}) after {ran:.1f} s; restart=no")
        else:
            if ran >= STABLE_S:
                child.backoff_n = 0
            if child.backoff_n >= proc.restart_limit:
                child.state = "failed"
                self.log(f"{proc.id} died ({_signal_name(code)}) after {ran:.1f} s, "
                         f"{child.backoff_n + 1} times in a row: giving up on it "
                         f"(restart-limit={proc.restart_limit})")
                self.write_state()
                return
            delay = min(max(proc.restart_delay_s, MIN_RESTART_DELAY_S) * (2 ** child.backoff_n),
                        MAX_BACKOFF_S)
            child.backoff_n += 1
            child.state, child.next_start = "backoff", now + delay
            self.log(f"{proc.id} died ({_signal_name(code)}) after {ran:.1f} s; "
                     f"restart {child.restarts + 1} in {delay:g} s")
        self.write_state()

    def _restart_due(self, now: float) -> None:
        for child in self.children:
            if child.state == "backoff" and now >= child.next_start:
                child.restarts += 1
                self._start(child)
                for fired in self.rules.on_event("component-restarted", child.proc.id):
                    self._act(fired)

    def _stop_child(self, child: Child) -> None:
        if child.popen is None or child.popen.poll() is not None:
            if child.state == "backoff":
                child.state = "stopped"
            return
        child.popen.send_signal(signal.SIGTERM)
        try:
            child.popen.wait(STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.log(f"{child.proc.id} did not stop in {STOP_TIMEOUT_S:g} s; killing it")
            child.popen.kill()
            child.popen.wait()
        child.exit = child.popen.returncode
        child.state = "stopped"
        if child.reader is not None:
            child.reader.join(timeout=2.0)
        self.log(f"{child.proc.id} stopped ({_signal_name(child.exit)})")
        self.write_state()

    # -- status and rules -------------------------------------------------------
    def _subscribe(self, proc: Process) -> None:
        if proc.status is not None:
            self.subs[proc.id] = Subscriber(proc.status, topics=("status",))

    def _read_status(self, ident: str, timeout_ms: int = 0) -> None:
        sub = self.subs.get(ident)
        if sub is None:
            return
        while True:
            msg = sub.recv(timeout_ms)
            timeout_ms = 0
            if msg is None:
                return
            if msg.kind != "status" or not isinstance(msg.value, dict):
                continue
            child = self.by_id[ident]
            child.status, child.status_at = dict(msg.value), time.monotonic()
            self._follow_log(child.proc, child.status.get("log"))
            for fired in self.rules.on_status(ident, child.status, child.status_at):
                self._act(fired)

    @staticmethod
    def _follow_log(proc: Process, log: object) -> None:
        """The log the sim really writes (it never overwrites: an existing name becomes
        NAME-2.jsonl), so a restart recovers the right one."""
        if proc.kind != "sim" or not isinstance(log, str) or proc.recover_argv is None:
            return
        if proc.log is None or Path(log) != proc.log:
            proc.log = Path(log)
            proc.recover_argv[-1] = log

    def _command(self, target: str, name: str, args: dict[str, object] | None = None) -> bool:
        proc = self.plan.process(target)
        if proc.cmd is None:
            self.log(f"{target} takes no commands; {name} skipped")
            return False
        pub = self.pubs.get(target)
        if pub is None:
            pub = self.pubs[target] = Publisher(">" + proc.cmd, bind=False, replay=False)
        if not pub.wait_for_subscribers(1, timeout=3.0):
            self.log(f"{target} does not listen for commands; {name} not sent")
            return False
        pub.publish_cmd(Command(t=0.0, cmd=name, args=args or {}))
        return True

    def _act(self, fired: Fired) -> None:
        rule = fired.rule
        why = f"rule on {rule.event} (line {rule.where.line})"
        detail = "".join(f", {k} {v}" for k, v in fired.detail.items())
        self.log(f"{why}{detail}: {', '.join(a.name for a in rule.actions)}")
        for action in rule.actions:
            target = fired.target
            kiosk = target is not None and self.plan.process(target).kind == "kiosk"
            if action.name == "show-message":
                text = action.attrs["text"]
                self.messages.append(text)
                self.log(f"message: {text}")
                if kiosk and target is not None:
                    self._command(target, "message", {"text": text})
            elif action.name == "restart":
                self._restart(action.attrs["component"])
            elif target is None:
                continue
            elif action.name == "save-to-gallery":
                if kiosk:
                    self._command(target, "save")
                else:
                    self._save_to_gallery(target, action.attrs.get("gallery"))
            elif action.name == "clear":
                self._command(target, "fresh" if kiosk else "clear")
            elif action.name in ("save", "dry", "new-layer"):
                self._command(target, action.name.replace("-", "_"))
        self.write_state()

    def _restart(self, ident: str) -> None:
        child = self.by_id[ident]
        self.log(f"restarting {ident} (rule)")
        self._stop_child(child)
        child.restarts += 1
        self._start(child)

    def _save_to_gallery(self, target: str, gallery_id: str | None) -> None:
        """Checkpoint the sim (``save``), then render its checkpoint into the gallery."""
        child = self.by_id[target]
        before = int(child.status.get("autosaves", 0))
        if not self._command(target, "save"):
            return
        deadline = time.monotonic() + SAVE_TIMEOUT_S
        while time.monotonic() < deadline and int(child.status.get("autosaves", 0)) <= before:
            self._read_status(target, 100)
        if int(child.status.get("autosaves", 0)) <= before:
            self.log(f"{target} did not save within {SAVE_TIMEOUT_S:g} s; nothing to the "
                     "gallery")
            return
        galleries = self.plan.galleries
        directory = galleries[gallery_id] if gallery_id else next(iter(galleries.values()))
        directory.mkdir(parents=True, exist_ok=True)
        try:
            state = CanvasState.load(child.status["autosave"])
            renderer = get_profile(str(child.status.get("profile", "watercolor"))).renderer
            name = f"{self.plan.blueprint.name}-{time.strftime('%Y%m%d-%H%M%S')}"
            out = directory / f"{name}.png"
            n = 2
            while out.exists():
                out, n = directory / f"{name}-{n}.png", n + 1
            write_image(str(out), render_state(state, renderer))
        except Exception as exc:  # the station goes on; the failure is logged
            self.log(f"saving {target}'s painting to the gallery failed: {exc}")
            return
        self.saved.append(out)
        self.log(f"{target}'s painting saved to {out}")

    # -- the run ----------------------------------------------------------------
    def _sources_done(self) -> bool:
        sources = [c for c in self.children if c.proc.source]
        return bool(sources) and all(c.state in ("finished", "failed") for c in sources)

    def _drained(self, now: float) -> bool:
        """Every painter alive (a fresh status) and its sample count unchanged for
        :data:`DRAIN_S`: a starved painter publishes no status, so it is not taken for a
        finished one."""
        if self._sources_done_at is None:
            self._sources_done_at = now
        quiet = now - self._sources_done_at >= DRAIN_S
        for c in self.children:
            if c.proc.status is None or c.state != "running":
                continue
            samples = c.status.get("samples")
            last, since = self._drain.get(c.proc.id, (None, now))
            if samples != last:
                self._drain[c.proc.id] = (samples, now)
                quiet = False
            elif now - since < DRAIN_S or now - c.status_at > FRESH_STATUS_S:
                quiet = False
        return quiet

    def run(self) -> int:
        def on_signal(signum: int, frame: object) -> None:
            self.stop_requested.set()

        old = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
        t0 = time.monotonic()
        notify = sdnotify.notifier()
        notify.auto_ready = False  # ready once every component is up, not at its first read
        self.write_state()
        try:
            for child in self.children:
                if self.stop_requested.is_set():
                    break
                self._subscribe(child.proc)
                self._start(child)
                self._wait_ready(child)
            if not self.stop_requested.is_set():
                self.log(f"{self.plan.blueprint.name}: {len(self.children)} components up")
                notify.ready(f"{len(self.children)} components up")
                for fired in self.rules.on_event("started"):
                    self._act(fired)
            while not self.stop_requested.is_set():
                notify.alive()  # this loop turning is what the watchdog watches
                now = time.monotonic()
                if self.duration is not None and now - t0 >= self.duration:
                    self.log(f"--duration {self.duration:g} s reached")
                    break
                for child in self.children:
                    if child.state == "running" and child.popen is not None \
                            and child.popen.poll() is not None:
                        self._on_exit(child, now)
                self._restart_due(now)
                for ident in list(self.subs):
                    self._read_status(ident)
                for fired in self.rules.on_tick(now):
                    self._act(fired)
                if self.once and self._sources_done() and self._drained(now):
                    self.log("--once: the sources are done and the painting has taken "
                             "everything")
                    break
                if all(c.state in ("finished", "failed") for c in self.children):
                    self.log("every component has ended")
                    break
                self.stop_requested.wait(0.05)
        finally:
            notify.stopping()
            code = self.shutdown()
            for s, handler in old.items():
                signal.signal(s, handler)
        return code

    def shutdown(self) -> int:
        """``stopping`` rules, then SIGTERM in reverse start order, each awaited."""
        if not self.stopping:
            for ident in list(self.subs):
                self._read_status(ident)
            for fired in self.rules.on_event("stopping"):
                self._act(fired)
        self.stopping = True
        self.write_state()
        for child in reversed(self.children):
            self._stop_child(child)
        for sub in self.subs.values():
            sub.close()
        for pub in self.pubs.values():
            pub.close()
        self.subs.clear()
        self.pubs.clear()
        self.write_state()
        failed = [c.proc.id for c in self.children if c.state == "failed"
                  or (c.exit not in (0, None))]
        if failed:
            self.log(f"stopped; failed: {', '.join(failed)}")
            return 1
        self.log("stopped")
        return 0
