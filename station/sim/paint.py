"""Headless painting: a session log (or device trace) in, a PNG (and state, stats) out.

What happens on bad input (interfaces.md: exit 2, one line, nothing painted lost):

* a problem found before painting starts — unreadable or malformed header,
  unknown profile, impossible ``--size``, unsupported input format — raises
  :class:`~station.errors.BadInput` and writes nothing;
* a bad record in the middle (malformed line, unknown pigment, wrong command
  arguments, time going back) stops the replay *at that record*: every earlier
  record has been applied and simulated up to its time, pending brush stamps
  are handed to the canvas, and then the PNG, ``--state`` and ``--stats`` are
  written as usual before the error is raised (the message says the painting
  up to that point was written).
"""

from __future__ import annotations

import itertools
import json
import logging
import math
import os
import re
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from station import boundedio, sizes
from station.backends.factory import (  # auto: resolve_auto decides, once
    create_distributed,
    make_backend,
)
from station.backends.protocol import CanvasBackend
from station.canvas.palette import default_palette
from station.canvas.paper import PAPER_PRESETS
from station.canvas.profiles import get_profile
from station.canvas.state import CanvasState
from station.errors import BadInput, StationError
from station.events import Command, PenSample
from station.progress import Progress
from station.render.km import to_srgb8, to_srgb16
from station.render.png import write_png
from station.render.upscale import render_scaled
from station.sessionlog import SessionHeader, SessionLogReader
from station.sim.player import MAX_PAINTING_SECONDS, MAX_RATE, SessionPlayer
from station.sim.undo import UndoHistory, log_mentions_undo

log = logging.getLogger(__name__)

TRACE_SUFFIXES = (".hid", ".hidrec", ".evemu", ".evm", ".yaml", ".yml")
MAX_CELLS = sizes.MAX_CELLS


class PaintInputError(BadInput):
    """The input of ``station paint`` cannot be painted.

    ``result`` is set when the painting up to a bad record was written.
    """

    result: PaintResult | None = None


def parse_size(text: str, where: str = "--size") -> tuple[int, int]:
    """``"WxH"`` → ``(W, H)``; anything impossible raises :class:`PaintInputError`."""
    w, h = sizes.parse_size(text, where, PaintInputError)
    sizes.check_memory(w, h, where, PaintInputError)
    return w, h


BYTES_PER_CELL = sizes.BYTES_PER_CELL


def check_size(w: int, h: int, where: str, available: int | None = None) -> None:
    """Refuse a canvas too small, too large for the format, or larger than the memory
    here allows (one line giving the size and the memory), before anything is made."""
    sizes.check_size(w, h, where, PaintInputError)
    sizes.check_memory(w, h, where, PaintInputError, available)


def check_outputs(targets: Iterable[tuple[str | None, str]]) -> None:
    """Refuse output paths that cannot be written: ``(path, flag)`` pairs, ``None`` skipped."""
    for target, flag in targets:
        if target:
            parent = Path(target).resolve().parent
            if not parent.is_dir():
                raise PaintInputError(f"directory {str(parent)!r} does not exist", flag)
            if Path(target).is_dir():
                raise PaintInputError(f"{target!r} is a directory, not a file name", flag)


@dataclass
class PaintResult:
    """What a paint run produced."""

    width: int
    height: int
    profile: str
    backend: str
    renderer: str
    steps: int
    painting_seconds: float
    wall_seconds: float
    counters: dict[str, Any] = field(default_factory=dict)
    written: list[str] = field(default_factory=list)
    error: BadInput | None = None
    root: bool = True
    """False on the ranks of a distributed run that do not write (nor print)."""


# -- inputs -------------------------------------------------------------------------
class _Source:
    """A header and a stream of records with a ``where`` for messages."""

    def __init__(self, header: SessionHeader | None, records: Iterable[PenSample | Command],
                 where: Callable[[], str], close: Callable[[], None] | None = None) -> None:
        self.header = header or SessionHeader()
        self.has_header = header is not None
        self.records = records
        self.where = where
        self._close = close

    def close(self) -> None:
        if self._close is not None:
            self._close()


def open_input(path: str, canvas: tuple[int, int] = (800, 600), mapping: str = "fit") -> _Source:
    """Open a session log, or a device trace when the drivers can read it.

    A trace's pen samples are mapped onto ``canvas`` (width, height) by ``mapping``
    (``fit`` keeps the tablet's aspect ratio, ``stretch`` fills the canvas).
    """
    if path.lower().endswith(TRACE_SUFFIXES):
        return _open_trace(path, canvas, mapping)
    reader = SessionLogReader(path)
    return _Source(reader.header, reader, lambda: f"{reader.name}:{reader.line_no}",
                   reader.close)


def _open_trace(path: str, canvas: tuple[int, int], mapping: str) -> _Source:
    """A device trace through ``station.drivers.traces`` (issue 4)."""
    if not os.path.exists(path):
        raise PaintInputError("no such file", path)
    # in the function: a trace pulls in the driver pipeline and its transports, which a
    # session log (the common input) never needs
    from station.drivers.normalise import NormaliserConfig
    from station.drivers.pipeline import iter_trace_samples as reader

    samples = iter(reader(path, config=NormaliserConfig(mapping=mapping, canvas=canvas)))
    # The drivers read the whole trace on the first sample: a trace that does not
    # parse (or holds no pen device) is refused before anything is painted.
    first = next(samples, None)
    if first is None:
        raise PaintInputError("the trace holds no pen samples: nothing to paint", path)
    count = [0]

    def counted() -> Iterator[PenSample | Command]:
        for s in itertools.chain([first] if first is not None else [], samples):
            count[0] += 1
            if isinstance(s, (PenSample, Command)):
                yield s

    # a trace has no header: the session defaults (800x600 watercolor) unless overridden
    return _Source(None, counted(), lambda: f"{path}: sample {count[0]}")


def _session_length(path: str) -> float:
    """Session time plus waits of a log, from a quick scan (for progress only)."""
    last = waited = 0.0
    try:
        boundedio.check_regular(path, path)
        with open(path, encoding="utf-8") as fh:
            next(fh, None)
            for line in fh:
                m = re.search(r'"t":\s*([0-9.eE+-]+)', line)
                if m:
                    last = max(last, float(m.group(1)))
                if '"wait"' in line:
                    s = re.search(r'"seconds":\s*([0-9.eE+-]+)', line)
                    if s:
                        waited += float(s.group(1))
    except (OSError, ValueError, UnicodeDecodeError):
        return 0.0
    return last + waited


# -- painting ------------------------------------------------------------------------
def load_resume_state(path: str, size: tuple[int, int] | None, profile: str | None,
                      flag: str = "--resume") -> CanvasState:
    """The canvas state to continue from; ``--size``/``--profile`` must agree with it."""
    state = CanvasState.load(path)  # missing or corrupt file → BadInput
    if size is not None and size != (state.width, state.height):
        raise PaintInputError(f"--size {size[0]}x{size[1]} differs from the resumed canvas "
                              f"({state.width}x{state.height})", flag)
    if profile is not None and profile != state.profile:
        raise PaintInputError(f"--profile {profile} differs from the resumed canvas's "
                              f"({state.profile}); switch with a profile command instead", flag)
    return state


def paint(
    input_path: str,
    out_png: str | None,
    size: tuple[int, int] | None = None,
    profile: str | None = None,
    backend: str = "auto",
    stats_path: str | None = None,
    state_path: str | None = None,
    bits: int = 8,
    rate: float | None = None,
    settle: float = 0.0,
    progress: bool | None = None,
    backend_opts: Mapping[str, object] | None = None,
    resume: str | None = None,
    mapping: str = "fit",
    render_scale: int = 1,
    distributed: bool = False,
) -> PaintResult:
    """Paint ``input_path`` headless; see the module docstring for errors.

    ``mapping`` (``fit`` | ``stretch``) maps a device trace's tablet onto the
    canvas.  ``resume`` continues a saved canvas state (``--state`` of an earlier run)
    instead of blank paper: its size, profile and seed win over the session
    header's; brush sizes are not rescaled.

    ``distributed``: every rank of the MPI job runs this same call (``mpiexec -n N
    station paint ... --distributed``) on a :class:`DistributedCanvas`; rank 0 writes
    the outputs (see docs/distributed.md).

    Returns the :class:`PaintResult`; a bad record mid-file raises after the
    outputs are written (``result.error`` is set on the exception as
    ``exc.result``).
    """
    if bits not in (8, 16):
        raise PaintInputError(f"--bits {bits} must be 8 or 16", "--bits")
    if isinstance(render_scale, bool) or not isinstance(render_scale, int) \
            or not 1 <= render_scale <= 4:
        raise PaintInputError(f"--scale {render_scale} must be an integer 1..4", "--scale")
    if not (math.isfinite(settle) and 0 <= settle <= MAX_PAINTING_SECONDS):
        raise PaintInputError(f"--settle {settle:g} must be 0..{MAX_PAINTING_SECONDS:g} seconds "
                              "(the longest painting time a session may have)", "--settle")
    if rate is not None and not (math.isfinite(rate) and 0 < rate <= MAX_RATE):
        raise PaintInputError(f"--rate {rate:g} must be > 0 and at most {MAX_RATE:g} steps/s",
                              "--rate")
    check_outputs(((out_png, "-o"), (state_path, "--state"), (stats_path, "--stats")))
    start = load_resume_state(resume, size, profile) if resume else None
    trace_canvas = size or ((start.width, start.height) if start is not None else (800, 600))
    source = open_input(input_path, trace_canvas, mapping)
    try:
        header = source.header
        prof_name = start.profile if start is not None else (profile or header.profile)
        prof = get_profile(prof_name)  # unknown → BadInput
        if start is not None:
            width, height = start.width, start.height
        elif size is not None:
            width, height = size
        else:
            width, height = header.width, header.height
            check_size(width, height, f"{input_path}:1")
        # Brush sizes are in cells of the canvas the session was made for (a
        # trace has no such canvas: its brush is the profile's, in cells).
        scale = (math.sqrt((width / header.width) * (height / header.height))
                 if source.has_header and start is None else 1.0)
        sim = header.extra.get("sim")
        logged_rate = sim.get("rate") if isinstance(sim, dict) else None
        if rate is None and isinstance(logged_rate, (int, float)) \
                and not isinstance(logged_rate, bool):
            rate = float(logged_rate)  # the rate the session was recorded at
        seed = start.seed if start is not None else header.seed
        canvas: CanvasBackend
        backend_opts = {**session_paper(header, f"{input_path}:1"), **(backend_opts or {})}
        if distributed:
            canvas, backend = create_distributed(backend, width, height, prof.name, seed,
                                               **(backend_opts or {}))
        else:
            canvas, backend = make_backend(backend, width, height, prof.name, seed,
                                           **(backend_opts or {}))
        if start is not None:
            canvas.load_state(start)
        palette = default_palette()
        player = SessionPlayer(canvas, width, height, prof.name, rate=rate, pigments=palette,
                               brush_scale=scale)
        if start is not None:
            player.layer_pigments.update(start.slots)
        if log_mentions_undo(input_path):  # undos replay against the strokes they undo
            UndoHistory(player)
        root = bool(getattr(canvas, "is_root", True))  # a distributed canvas: rank 0 shows it
        bar = Progress(_session_length(input_path) + settle, "painting", unit="s",
                       show=progress if root else False)

        def prog(p: SessionPlayer) -> None:
            bar.set(p.painting_time)

        t0 = time.monotonic()
        error: BadInput | None = None
        finished = False
        try:
            player.play(source.records, source.where, on_step=prog)
            if settle > 0:
                player.settle(settle, on_step=prog)
            finished = True
        except BadInput as exc:
            error = exc
        finally:
            bar.close(complete=finished)
        wall = time.monotonic() - t0
        result = PaintResult(
            width=width, height=height, profile=player.profile, backend=backend,
            renderer=str(getattr(canvas, "renderer", backend)), steps=player.counters.steps,
            painting_seconds=player.painting_time, wall_seconds=wall,
            counters={**player.counters.as_dict(), **player.brush_counters()},
            error=error, root=root,
        )
        write_outputs(canvas, result, out_png, state_path, stats_path, bits, render_scale)
    finally:
        source.close()
    if error is not None:
        written = ", ".join(result.written)
        msg = str(error) + (f" (painting up to here written: {written})" if written else "")
        failure = PaintInputError(msg)
        failure.result = result
        raise failure from None
    return result


def write_outputs(canvas: CanvasBackend, result: PaintResult, out_png: str | None,
                  state_path: str | None, stats_path: str | None, bits: int,
                  render_scale: int = 1) -> None:
    """Render and write the PNG (at ``render_scale`` pixels per cell), the state and the
    stats (each when asked).

    A distributed canvas gathers on every rank (collective calls) and its root writes.
    """
    root = bool(getattr(canvas, "is_root", True))
    try:
        if out_png:
            if render_scale > 1:
                st = canvas.state()
                rgb = render_scaled(st, get_profile(st.profile).renderer, render_scale) \
                    if root else None
            else:
                rgb = canvas.render()
            if root and rgb is not None:  # rgb is None on the other ranks only
                write_image(out_png, rgb, bits)
            result.written.append(out_png)
        if state_path:
            st = canvas.state()
            if root:
                st.save(state_path)
            result.written.append(state_path)
        if stats_path:
            stats = canvas.stats()
            if not root:
                return
            out = {**stats, "player": result.counters}  # the canvas's books, then ours
            with open(stats_path, "w", encoding="utf-8") as fh:
                json.dump(out, fh, indent=2)
                fh.write("\n")
            result.written.append(stats_path)
    except OSError as exc:
        raise StationError(f"cannot write output: {exc}") from None


def write_image(path: str, rgb: np.ndarray, bits: int = 8) -> None:
    """Write linear reflectance ``rgb`` (H, W, 3) as an sRGB PNG of ``bits`` per channel."""
    write_png(path, to_srgb16(rgb) if bits == 16 else to_srgb8(rgb))


def session_paper(header: SessionHeader, where: str) -> dict[str, str]:
    """The paper a session chose (header key ``paper``: a name of
    ``station/data/papers.json``) as a backend option; {} for the profile's own paper.
    An unknown name is bad input (exit 2)."""
    paper = header.extra.get("paper")
    if paper is None:
        return {}
    if not isinstance(paper, str) or paper not in PAPER_PRESETS:
        raise PaintInputError(f"header paper {paper!r:.40} is not a known paper "
                              f"({', '.join(PAPER_PRESETS)})", where)
    return {"paper": paper}
