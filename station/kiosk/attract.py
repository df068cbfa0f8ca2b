"""The attract screen: paintings from the gallery being painted, one line of invitation.

After ``--attract-after`` seconds without the pen the kiosk shows, over the
canvas area, the gallery's paintings being painted — their replays
(``<gallery>/<id>/replay.webp``, made by ``station gallery make`` from each
painting's session log), the newest first, one after another, each ending on
its finished picture — under one line: :data:`INVITATION`.  A gallery with no
replay yet (a new installation) shows a demo stroke painting itself across the
area instead (:func:`demo_stroke`).  It gives way at the first touch: any pen
sample in proximity, a mouse's move or click, a finger on a touchscreen (the
idle clock's activity).

Frames are decoded one at a time as they are due (a replay is about 48 frames of
the painting's size; decoded at once that is tens of megabytes per painting).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

log = logging.getLogger(__name__)

INVITATION = "Pick up the pen (or touch the screen) and paint!"
REPLAY_NAME = "replay.webp"
MAX_REPLAYS = 12  # the newest paintings shown in turn
HOLD_LAST_S = 2.5  # the finished painting stays this long before the next
DEMO_PERIOD_S = 6.0  # the demo stroke paints itself over this long, then again


def gallery_replays(root: Path, most: int = MAX_REPLAYS) -> list[Path]:
    """The replays in the gallery ``root``, newest first (hidden directories skipped)."""
    found = []
    try:
        for d in root.iterdir():
            p = d / REPLAY_NAME
            if not d.name.startswith(".") and p.is_file():
                found.append((p.stat().st_mtime, p))
    except OSError:
        return []
    found.sort(reverse=True)
    return [p for _, p in found[:most]]


class AttractShow:
    """The replays in turn (see the module docstring); :meth:`frame` gives the picture
    due at a time and whether it changed since the last call."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.replays: list[Path] = []
        self._index = -1
        self._image: Image.Image | None = None
        self._durations: list[float] = []
        self._start = 0.0
        self._shown: tuple[int, int] | None = None  # (replay, frame) last given

    def start(self, now: float) -> None:
        """The attract screen comes up: look in the gallery again, begin with the newest."""
        self.replays = gallery_replays(self.root)
        self._index = -1
        self._shown = None
        self._next(now)

    def _next(self, now: float) -> None:
        if self._image is not None:
            self._image.close()
            self._image = None
        for _ in range(len(self.replays)):
            self._index = (self._index + 1) % len(self.replays)
            try:
                img = Image.open(self.replays[self._index])
                n = int(getattr(img, "n_frames", 1))
                durations = []
                for k in range(n):
                    img.seek(k)
                    durations.append(max(0.04, float(img.info.get("duration", 100)) / 1000))
            except (OSError, UnidentifiedImageError, ValueError) as exc:
                log.warning("attract: cannot play %s: %s", self.replays[self._index], exc)
                continue
            durations[-1] = max(durations[-1], HOLD_LAST_S)
            self._image, self._durations, self._start = img, durations, now
            return
        self.replays = []

    @property
    def playing(self) -> bool:
        """Whether a replay plays (else the demo stroke shows)."""
        return self._image is not None

    def frame(self, now: float) -> tuple[np.ndarray | None, bool]:
        """The replay's frame due at ``now`` (RGBA uint8, H×W×4; ``None`` without a
        replay) and whether it is a new one."""
        img = self._image
        if img is None:
            return None, False
        t = now - self._start
        total = sum(self._durations)
        if t >= total:
            self._next(now)
            img = self._image
            if img is None:
                return None, False
            t = 0.0
        k, acc = 0, 0.0
        while k < len(self._durations) - 1 and acc + self._durations[k] <= t:
            acc += self._durations[k]
            k += 1
        key = (self._index, k)
        new = key != self._shown
        self._shown = key
        img.seek(k)
        return np.asarray(img.convert("RGBA")), new


def demo_stroke(now: float, width: float, height: float, steps: int = 48
                ) -> list[tuple[float, float]]:
    """The points (window pixels from the area's top left) of the demo stroke as far as
    it has painted itself at ``now``: an S-curve across the area, drawn over
    :data:`DEMO_PERIOD_S` and then again."""
    f = (now % DEMO_PERIOD_S) / (DEMO_PERIOD_S * 0.8)
    n = max(2, int(min(1.0, f) * steps))
    s = np.linspace(0.0, min(1.0, f), n)
    xs = width * (0.15 + 0.7 * s)
    ys = height * (0.55 + 0.18 * np.sin(2 * math.pi * s * 1.2))
    return [(float(x), float(y)) for x, y in zip(xs, ys, strict=True)]
