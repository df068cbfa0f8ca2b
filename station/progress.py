"""Progress bars for long work (paint, demo, replay, benchmarks): tqdm on a terminal,
a plain line every few seconds otherwise.

Output goes to stderr, so stdout stays clean for JSON and session logs.  When stderr
is not a terminal (a pipe, a log file, CI, a systemd journal) a :class:`Progress`
writes one line every :data:`LINE_EVERY_S` seconds (``painting: 42% (12.6/30 s),
8 s so far``) and nothing else: work that ends sooner stays silent, and a command
running for minutes says it is alive.
"""

from __future__ import annotations

import io
import os
import sys
import time
from types import TracebackType
from typing import IO

from tqdm import tqdm

LINE_EVERY_S = 5.0
"""Seconds between two progress lines when stderr is not a terminal."""


def _columns(stream: IO[str]) -> int:
    """Width of the terminal behind ``stream``; 0 when unknown (a pty nobody sized)."""
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
        return 0


def on_terminal(stream: IO[str]) -> bool:
    """Whether ``stream`` is an interactive terminal (closed or odd streams are not)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, OSError, ValueError):
        return False


class Progress:
    """A progress bar of ``total`` units of work on ``stream`` (default stderr).

    ``show``: None (the default) shows it only when ``stream`` is a terminal; True or
    False force it.  ``total`` None (or 0: an estimate that found nothing) counts
    without a percentage.  Redraws at most
    every ``interval`` seconds, so per-step updates cost little.
    """

    def __init__(self, total: float | None, desc: str, unit: str = "it",
                 stream: IO[str] | None = None, show: bool | None = None,
                 interval: float = 0.25) -> None:
        self.stream = sys.stderr if stream is None else stream
        self.enabled = on_terminal(self.stream) if show is None else bool(show)
        # no terminal and not told: plain lines, now and then
        self.lines = show is None and not self.enabled and not getattr(self.stream, "closed",
                                                                        True)
        self.desc, self.unit, self.total = desc, unit, total
        self.done = 0.0
        self._t0 = time.monotonic()
        self._next_line = self._t0 + LINE_EVERY_S
        self._bar: tqdm | None = None
        if self.enabled:
            self._bar = tqdm(total=total or None, desc=desc, unit=unit,
                             unit_scale=isinstance(total, float),
                             file=self.stream, mininterval=interval, leave=True,
                             # follow resizes; a terminal of width 0 would hide the bar
                             dynamic_ncols=_columns(self.stream) > 0,
                             ncols=None if _columns(self.stream) > 0 else 80)

    def update(self, n: float = 1) -> None:
        """``n`` more units done."""
        self.done += n
        if self._bar is not None:
            self._bar.update(n)
        elif self.lines:
            self._maybe_line()

    def set(self, done: float) -> None:
        """``done`` units done in all (never moves back)."""
        if self._bar is not None and done > self._bar.n:
            self._bar.update(done - self._bar.n)
        if done > self.done:
            self.done = done
            if self.lines:
                self._maybe_line()

    def _maybe_line(self) -> None:
        now = time.monotonic()
        if now < self._next_line:
            return
        self._next_line = now + LINE_EVERY_S
        if self.total:
            pct = min(100.0, 100.0 * self.done / self.total)
            what = f"{pct:.0f}% ({self.done:.4g}/{self.total:.4g} {self.unit})"
        else:
            what = f"{self.done:.4g} {self.unit}"
        try:
            self.stream.write(f"{self.desc}: {what}, {now - self._t0:.0f} s so far\n")
            self.stream.flush()
        except (OSError, ValueError):  # a closed pipe: progress is not worth failing for
            self.lines = False

    def note(self, text: str) -> None:
        """A short status after the bar (e.g. the configuration being measured)."""
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=False)

    def write(self, line: str) -> None:
        """A line printed above the bar; dropped when there is no bar."""
        if self._bar is not None:
            self._bar.write(line, file=self.stream)

    def close(self, complete: bool = False) -> None:
        """Draw the final state and end the line; ``complete``: the work is finished,
        show the whole total (a total that was an estimate may not be reached exactly)."""
        if self._bar is not None:
            if complete and self._bar.total is not None:
                self.set(self._bar.total)
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
