"""What ``--backend auto`` means on this machine: measured once, then cached (issue 26).

On first use ``auto`` runs a short, bounded probe, in a child process (its GL contexts
stay out of the caller's: a kiosk's window context stays current; a broken driver
cannot take the caller down): every backend that can run here
(``numpy``; ``cpu`` with numba; ``gl`` when an OpenGL 4.3 context can be made, a CPU
rasterizer included) steps a fully wet :data:`PROBE_SIZE` canvas — the case that
decides whether a visitor's wet sky keeps real time — for about
:data:`PROBE_SECONDS` after :data:`PROBE_WARMUP` untimed steps (shader compiles,
numba's cache), and the one with the most steps per second is the choice.

The choice and its figures are kept in ``backend-choice.json`` in the cache
directory (``$STATION_CACHE_DIR``, else platformdirs' user cache dir,
``~/.cache/station``), keyed by the station's version, the machine (CPU model and
count, architecture, numba present) and the GL renderer: when any of them changes
the probe runs again.  A cache that is missing, unreadable, corrupt or of another
shape is measured over (and rewritten atomically); one that cannot be written is
logged and the measurement used for this process.  If no backend can be measured
the old fixed rule decides (:func:`fixed_rule`).  ``station doctor`` shows the
choice and its figures.

The child reports each backend as it finishes, so a probe that runs out of time (a
first run on a busy machine compiles the cpu backend inside it: minutes) keeps what it
measured.  A backend the probe did not reach, or was still measuring when its time ran
out, is *pending*: this process uses the measured backends, or the fixed rule where
the rule's pick is pending (a cpu backend still compiling is no evidence against it),
and the next use measures only the pending backends (numba's cache keeps what the
killed child compiled, so each attempt gets further).  A backend whose child died while
measuring it failed for good (a crashing driver is not probed at every start).
"""

from __future__ import annotations

import json
import logging
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import platformdirs

import station
from station.errors import StationError

log = logging.getLogger(__name__)

CACHE_NAME = "backend-choice.json"
PROBE_SIZE = (384, 288)
"""Width, height of the probe's wet canvas (cells)."""
PROBE_WARMUP = 2
PROBE_SECONDS = 0.3
"""Timed seconds per backend (at least :data:`PROBE_MIN_STEPS` steps)."""
PROBE_MIN_STEPS = 3
PROBE_MAX_SECONDS = 5.0
"""A backend still short of its steps after this long stops (its figure is what it did)."""
SCHEMA = 1


def cache_dir() -> Path:
    base = os.environ.get("STATION_CACHE_DIR")
    return Path(base) if base else Path(platformdirs.user_cache_dir("station",
                                                                    appauthor=False))


def machine_key(numba: bool) -> str:
    """What identifies this machine's CPU side: model, count, architecture, numba."""
    model = platform.processor() or ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{platform.machine()}|{model}|{os.cpu_count()}|numba={'yes' if numba else 'no'}"


@dataclass
class Choice:
    """The measured meaning of ``auto``.

    Attributes:
        backend: the chosen backend.
        why: one line for logs and ``station doctor``.
        steps_per_s: each measured backend's steps per second on the probe canvas
            (``None`` for one that failed, with ``errors`` saying why).
        renderer: GL_RENDERER at the time (``None``: no GL context).
        cached: whether this came from the cache file rather than a probe just now.
    """

    backend: str
    why: str
    steps_per_s: dict[str, float | None] = field(default_factory=dict)
    errors: dict[str, str] = field(default_factory=dict)
    renderer: str | None = None
    version: str = ""
    machine: str = ""
    measured_at: float = 0.0
    probe: str = ""
    cached: bool = False
    pending: dict[str, str] = field(default_factory=dict)
    """Backends not measured yet (the probe ran out of time before or while measuring
    them), each with why; the next use measures them."""

    def as_dict(self) -> dict[str, object]:
        return {"schema": SCHEMA, "backend": self.backend, "why": self.why,
                "steps_per_s": self.steps_per_s, "errors": self.errors,
                "renderer": self.renderer, "version": self.version, "machine": self.machine,
                "measured_at": self.measured_at, "probe": self.probe,
                "pending": self.pending}

    @classmethod
    def from_dict(cls, data: object) -> Choice:
        """A cache file's contents; ValueError for anything of another shape."""
        if not isinstance(data, dict) or data.get("schema") != SCHEMA:
            raise ValueError("not a backend choice of this schema")
        backend, steps = data.get("backend"), data.get("steps_per_s")
        if not isinstance(backend, str) or not isinstance(steps, dict):
            raise ValueError("backend or steps_per_s missing")
        figures: dict[str, float | None] = {}
        for k, v in steps.items():
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ValueError(f"steps_per_s[{k!r}] is not a number")
            figures[str(k)] = None if v is None else float(v)
        if backend not in figures and figures:
            raise ValueError("the chosen backend was not measured")
        renderer = data.get("renderer")
        errors = data.get("errors", {})
        pending = data.get("pending", {})
        if not isinstance(pending, dict) or not set(pending) <= set(figures):
            raise ValueError("pending is not a map of measured names")
        return cls(backend=backend, why=str(data.get("why", "")), steps_per_s=figures,
                   errors={str(k): str(v) for k, v in errors.items()}
                   if isinstance(errors, dict) else {},
                   renderer=None if renderer is None else str(renderer),
                   version=str(data.get("version", "")), machine=str(data.get("machine", "")),
                   measured_at=float(data.get("measured_at", 0.0)),
                   probe=str(data.get("probe", "")), cached=True,
                   pending={str(k): str(v) for k, v in pending.items()})


def _wet(canvas: Any, width: int, height: int) -> None:
    """Water and two pigments everywhere, a slow swirl (``station bench sim``'s wash)."""
    rng = np.random.default_rng(7)
    dw = (0.6 + 0.2 * rng.random((height, width))).astype(np.float32)
    dp = {"French Ultramarine": (0.05 * rng.random((height, width))).astype(np.float32),
          "Burnt Umber": (0.05 * rng.random((height, width))).astype(np.float32)}
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
    canvas.add_sources(dw=dw, dp=dp, dvx=(6.0 * np.sin(yy * 2 * np.pi / height)),
                       dvy=(6.0 * np.cos(xx * 2 * np.pi / width)))


def probe_backend(name: str, make: Callable[..., Any], size: tuple[int, int] = PROBE_SIZE,
                  seconds: float | None = None) -> float:
    """Steps per second of backend ``name`` (made by ``make``) on a wet canvas, timed
    for ``seconds`` (default :data:`PROBE_SECONDS`)."""
    w, h = size
    seconds = PROBE_SECONDS if seconds is None else seconds
    canvas = make(name, w, h, "watercolor", 1, tiling=False)
    try:
        _wet(canvas, w, h)
        sync = getattr(canvas, "sync", lambda: None)
        for _ in range(PROBE_WARMUP):
            canvas.step()
        sync()
        steps = 0
        t0 = time.perf_counter()
        while True:
            canvas.step()
            steps += 1
            sync()
            elapsed = time.perf_counter() - t0
            if (steps >= PROBE_MIN_STEPS and elapsed >= seconds) or elapsed >= PROBE_MAX_SECONDS:
                return steps / elapsed
    finally:
        close = getattr(canvas, "close", None)
        if close is not None:
            close()


def measure_one(name: str, make: Callable[..., Any]) -> tuple[float | None, str]:
    """Backend ``name``'s steps per second, or ``None`` and why it could not run."""
    try:
        return round(probe_backend(name, make), 3), ""
    except (StationError, ImportError, RuntimeError, ValueError, OSError) as exc:
        why = " ".join(str(exc).split())[:300]
        log.warning("backend probe: %s failed: %s", name, why)
        return None, why


def decide(figures: dict[str, float | None], errors: dict[str, str], fallback: str,
           renderer: str | None, machine: str, pending: dict[str, str] | None = None
           ) -> Choice:
    """The choice from what was measured: the fastest backend; the fixed rule's
    ``fallback`` when nothing ran, or when ``fallback`` itself is still ``pending``."""
    pending = dict(pending or {})
    ran = {k: v for k, v in figures.items() if v is not None}
    w, h = PROBE_SIZE
    probe = f"{w}x{h} wet canvas, {PROBE_SECONDS:g} s per backend"
    later = (f"; not measured yet: {', '.join(sorted(pending))} (measured at the next use)"
             if pending else "")
    if fallback in pending:
        best = fallback
        seen = ", ".join(f"{k} {v:g}" for k, v in sorted(ran.items()))
        why = (f"{fallback} not measured yet ({pending[fallback]}): the fixed rule picks "
               f"{fallback}" + (f" (measured: {seen})" if seen else "") + later)
    elif ran:
        best = max(ran, key=lambda k: ran[k])
        others = ", ".join(f"{k} {v:g}" for k, v in sorted(ran.items()) if k != best)
        why = (f"measured: {best} {ran[best]:g} steps/s on a {w}x{h} wet canvas"
               + (f" (beside {others})" if others else "") + later)
    else:
        best = fallback
        why = f"no backend could be measured; the fixed rule picks {fallback}" + later
    figures = {**figures, **{k: None for k in pending}}
    return Choice(best, why, figures, dict(errors), renderer, station.__version__, machine,
                  time.time(), probe, pending=pending)


def measure(candidates: list[str], renderer: str | None, machine: str,
            make: Callable[..., Any], fallback: str) -> Choice:
    """Probe ``candidates`` in this process; the fastest is the choice (``fallback`` if
    none ran)."""
    figures: dict[str, float | None] = {}
    errors: dict[str, str] = {}
    for name in candidates:
        figures[name], why = measure_one(name, make)
        if why:
            errors[name] = why
    return decide(figures, errors, fallback, renderer, machine)


def load(path: Path | None = None) -> Choice | None:
    """The cached choice, or ``None`` when there is none or it cannot be used."""
    path = path or cache_dir() / CACHE_NAME
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError) as exc:
        log.warning("backend choice cache %s unreadable (%s): measuring again", path, exc)
        return None
    try:
        return Choice.from_dict(json.loads(text))
    except (ValueError, TypeError) as exc:  # JSONDecodeError is a ValueError
        log.warning("backend choice cache %s is corrupt (%s): measuring again", path, exc)
        return None


def save(choice: Choice, path: Path | None = None) -> bool:
    """Write ``choice`` atomically; False (logged) when the cache cannot be written."""
    path = path or cache_dir() / CACHE_NAME
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".backend-choice-", dir=path.parent)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                json.dump(choice.as_dict(), f, indent=2)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
    except OSError as exc:
        log.warning("backend choice not cached (%s: %s)", path, exc)
        return False
    return True


def still_valid(choice: Choice, renderer: str | None, machine: str,
                candidates: list[str]) -> bool:
    """Whether a cached choice was measured by this version on this machine and GL."""
    return (same_setting(choice, renderer, machine, candidates) and not choice.pending
            and choice.backend in candidates)


def same_setting(choice: Choice, renderer: str | None, machine: str,
                 candidates: list[str]) -> bool:
    """Whether ``choice`` was measured by this version on this machine and GL, for the
    same backends (complete or not)."""
    return (choice.version == station.__version__ and choice.machine == machine
            and choice.renderer == renderer and set(choice.steps_per_s) == set(candidates))


def resolve(candidates: list[str], renderer: str | None, machine: str,
            make: Callable[..., Any] | None, fallback: str, path: Path | None = None
            ) -> Choice:
    """The cached choice when still valid, else a fresh measurement (then cached):
    with ``make`` in this process, without it in a child (:func:`measure_in_child`)."""
    cached = load(path)
    if cached is not None and still_valid(cached, renderer, machine, candidates):
        return cached
    if cached is not None and cached.pending and same_setting(cached, renderer, machine,
                                                              candidates):
        # an earlier probe ran out of time: measure only what it did not reach
        names = [n for n in candidates if n in cached.pending]
        log.info("backend choice: measuring %s (not reached last time)", ", ".join(names))
        fresh = (measure_in_child(names, renderer, machine, fallback) if make is None
                 else measure(names, renderer, machine, make, fallback))
        # (the whole probe's death, "probe", is superseded by this measurement too)
        errors = {k: v for k, v in cached.errors.items() if k not in names and k != "probe"}
        choice = decide({**cached.steps_per_s, **fresh.steps_per_s},
                        {**errors, **fresh.errors}, fallback, renderer, machine,
                        fresh.pending)
        save(choice, path)
        return choice
    if cached is not None:
        log.info("backend choice cache is stale (version, machine or GL renderer "
                 "changed): measuring again")
    if make is None:
        choice = measure_in_child(candidates, renderer, machine, fallback)
    else:
        choice = measure(candidates, renderer, machine, make, fallback)
    save(choice, path)
    return choice


CHILD_TIMEOUT_S = 300.0
"""The probe in a child: a first run may compile the cpu backend (minutes on a loaded
2-core machine); past this what was measured decides and the rest is pending."""

# one JSON line as each backend starts and as it ends, flushed: a child killed at its
# deadline (or dead) still tells what it measured and what it was doing
_CHILD = """
import json, sys
from station.backends import choice
from station.backends.factory import create_backend
for name in json.loads(sys.argv[1])["candidates"]:
    print(json.dumps({"start": name}), flush=True)
    v, why = choice.measure_one(name, create_backend)
    print(json.dumps({"name": name, "steps_per_s": v, "error": why}), flush=True)
"""


def _text(out: str | bytes | None) -> str:
    if isinstance(out, bytes):
        return out.decode("utf-8", errors="replace")
    return out or ""


def read_child(candidates: list[str], stdout: str, *, died: str = "",
               timed_out: str = "") -> tuple[dict[str, float | None], dict[str, str],
                                             dict[str, str]]:
    """Figures, errors and pending backends from a probe child's output (JSON lines).

    A backend the child started but did not finish failed when the child ``died`` (it
    died measuring it), is pending when it ``timed_out``; backends it never reached are
    pending."""
    figures: dict[str, float | None] = {}
    errors: dict[str, str] = {}
    started = ""
    for line in stdout.splitlines():
        try:
            msg = json.loads(line)
        except ValueError:
            continue  # a library's chatter on stdout
        if not isinstance(msg, dict):
            continue
        if msg.get("start") in candidates:
            started = str(msg["start"])
        name, v = msg.get("name"), msg.get("steps_per_s")
        if name in candidates and (v is None or (isinstance(v, (int, float))
                                                 and math.isfinite(v) and v > 0)):
            figures[str(name)] = None if v is None else float(v)
            if msg.get("error"):
                errors[str(name)] = str(msg["error"])[:300]
            started = ""
    pending: dict[str, str] = {}
    for name in candidates:
        if name in figures:
            continue
        if name == started and died:
            figures[name] = None
            errors[name] = f"the probe died measuring it: {died}"[:300]
        elif name == started:
            pending[name] = f"still running after {timed_out}" if timed_out else "not reached"
        else:
            pending[name] = "not reached: " + (died or timed_out or "the probe stopped")
    return figures, errors, pending


def measure_in_child(candidates: list[str], renderer: str | None, machine: str,
                     fallback: str) -> Choice:
    """:func:`measure` in a child process: the probe's GL contexts never touch the
    caller's (a kiosk's window context stays current) and a broken driver cannot take
    the caller down.  What the child measured before it died or ran out of
    :data:`CHILD_TIMEOUT_S` counts; the rest is pending (:func:`read_child`)."""
    arg = json.dumps({"candidates": candidates})
    died = timed_out = ""
    try:
        proc = subprocess.run([sys.executable, "-c", _CHILD, arg], capture_output=True,
                              text=True, timeout=CHILD_TIMEOUT_S, check=False)
        out = proc.stdout
        if proc.returncode != 0:
            died = (proc.stderr.strip().splitlines() or
                    [f"exit status {proc.returncode}"])[-1][:200]
    except subprocess.TimeoutExpired as exc:
        out = _text(exc.stdout)
        timed_out = f"{CHILD_TIMEOUT_S:g} s"
    figures, errors, pending = read_child(candidates, out, died=died, timed_out=timed_out)
    if died or timed_out:
        log.warning("backend probe %s; measured: %s; pending: %s",
                    f"failed ({died})" if died else f"ran out of its {timed_out}",
                    ", ".join(k for k, v in figures.items() if v is not None) or "none",
                    ", ".join(pending) or "none")
    if died and not figures:
        errors["probe"] = died
    return decide(figures, errors, fallback, renderer, machine, pending)
