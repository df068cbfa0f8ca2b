"""The live simulation's settings, limits and records of its devices and counters
(:mod:`station.sim.live`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from station.events import PenSample

RESYNC_S = 1.0
STATUS_EVERY_S = 0.5
DRAIN_MAX = 2000  # messages handled between two steps at most (steps must go on)
# A bus flood (a broken or hostile publisher) is dropped and counted, so the sim's memory
# and its log grow at most at these rates: a tablet sends 100-233 samples/s, a gaming
# mouse 1000; beyond FLOOD_RATE per device (after a burst) samples are dropped.  Past
# MAX_DEVICES device names, samples of new names are dropped (each name costs state).
FLOOD_RATE = 4000.0
FLOOD_BURST = 8000.0
MAX_DEVICES = 64
MAX_WARNINGS = 256  # distinct warnings logged; beyond, they are only counted
SYNC_EVERY_S = 1.0  # fsync of the log (it reaches the kernel before every step)
SILENCE_INTERVALS = 3.0  # heartbeat intervals without a message: the device is silent
RECOVERED_STROKE_GRACE_S = 1.0  # a stroke open at a crash ends if its device stays quiet


@dataclass
class LiveConfig:
    """Settings of one ``station sim`` run."""

    bus: str | None
    width: int = 800
    height: int = 600
    profile: str = "watercolor"
    backend: str = "auto"
    seed: int = 0
    rate: float | None = None
    log_path: str | None = None  # None: a new log in the data directory
    state_path: str | None = None
    png_path: str | None = None
    status: str | None = None  # endpoint for status; "none" disables
    duration: float | None = None  # stop after this many seconds (tests, benchmarks)
    resume: str | None = None  # continue this saved canvas state (size, profile, seed)
    autosave: float = 30.0  # seconds between autosaves; 0 disables
    recover: str | None = None  # continue this session log (autosave + replay)
    cmd: str | None = None  # command endpoint for `station send`; "none" disables
    backend_opts: dict[str, Any] = field(default_factory=dict)  # e.g. ctx= of a kiosk window
    distributed: bool = False  # rank 0 of an MPI job: the canvas spans every rank
    keys: Path | None = None  # CURVE key directory for tcp endpoints (None: the default)
    client_key: str | None = None  # a client key pair of its own for connecting over tcp
    brush: dict[str, Any] | None = None  # a brush command's args, run (and logged) at start


def default_status_endpoint(bus: str | None) -> str:
    """Where status goes: the proxy's publisher side when subscribed to the
    proxy (``ipc:sub``), else a socket of our own, ``ipc:sim-status``."""
    if bus and bus.lstrip(">@") == "ipc:sub":
        return ">ipc:pub"
    return "@ipc:sim-status"


DEFAULT_CMD_ENDPOINT = "ipc:sim-cmd"
UNREAD_COUNT_S = 3.0  # reading what is still queued at stop, to count it (a flood's HWM)
KIOSK_CMD_ENDPOINT = "ipc:kiosk-cmd"  # a kiosk's own: a `stop` for a sim never reaches it


@dataclass
class DeviceState:
    """What the simulation knows of one pen device."""

    last_seen: float  # monotonic seconds of its last message
    heartbeat_s: float | None = None  # its publisher's interval; None: never sent one
    silent: bool = False
    touching: bool = False  # its last applied sample touched the paper
    last_sample: PenSample | None = None
    resume_seq: int | None = None  # after a recovery: the last device seq in the log

    def timeout(self) -> float | None:
        if self.heartbeat_s is None:
            return None
        return SILENCE_INTERVALS * self.heartbeat_s + 0.1


@dataclass
class Counters:
    samples: int = 0
    commands: int = 0
    bad_commands: int = 0
    bad_samples: int = 0
    dropped_sources: int = 0
    synthetic_pen_ups: int = 0
    recovered_duplicates: int = 0  # replayed samples the log already had (dropped)
    missed_while_down: int = 0  # device samples sent while no sim was listening
    autosaves: int = 0
    flood_dropped: int = 0  # pen samples dropped beyond FLOOD_RATE or MAX_DEVICES
    warnings_suppressed: int = 0  # warnings past MAX_WARNINGS (counted, not logged)
    unread_at_stop: int = 0  # pen samples still queued on the bus when it stopped
    extra: dict[str, int] = field(default_factory=dict)


class StepHooks(Protocol):
    """What a host runs around every step of its :class:`LiveCore` (the kiosk: its undo
    checkpoints' copies before, the tiles its display must redraw before and after), and
    how it runs the step's canvas part (``job``: the stamps' sum and add, the beads, the
    kernel; :meth:`SessionPlayer.apply_step <station.sim.player.SessionPlayer.apply_step>`),
    after the step has taken what it needs from the brush (the kiosk: with its lock
    released, in its kernel thread)."""

    def before_step(self) -> None: ...

    def run_step(self, job: Callable[[], None]) -> None: ...

    def after_step(self) -> None: ...
