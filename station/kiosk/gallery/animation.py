"""A painting's creation replayed from its session log: the frames, and the
animated WebP/GIF made of them (the gallery's ``replay.webp``)."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from station.backends.factory import fastest_cpu_backend, make_backend
from station.canvas.palette import default_palette
from station.canvas.profiles import get_profile
from station.events import Command
from station.render.km import to_srgb8
from station.sessionlog import read_session
from station.sim.player import SessionPlayer


# -- replay animation ------------------------------------------------------------
def replay_frames(log_path: str | os.PathLike[str], frames: int = 48, width: int = 400,
                  backend: str | None = None,
                  final: Callable[[Any, str], None] | None = None) -> Iterator[np.ndarray]:
    """sRGB8 frames of a session log replayed on a canvas backend: about ``frames``
    evenly spaced in painting time, then the final canvas; scaled to ``width`` px.
    ``final(canvas, renderer)`` is called with the finished canvas (a print of it)."""
    from PIL import Image


    header, records = read_session(log_path)
    # None: a CPU backend.  A replay runs in the background under a memory cap: no GL
    # context (a GL driver's threads share the cap and crash on it), and no `auto` probe
    canvas, _ = make_backend(backend or fastest_cpu_backend(), header.width, header.height,
                             header.profile, header.seed)
    sim = header.extra.get("sim") if isinstance(header.extra.get("sim"), dict) else {}
    rate = sim.get("rate") if isinstance(sim, dict) else None
    player = SessionPlayer(canvas, header.width, header.height, header.profile,
                           rate=float(rate) if isinstance(rate, (int, float)) else None,
                           pigments=default_palette())
    waits = sum(float(r.args.get("seconds", 0.0)) for r in records
                if isinstance(r, Command) and r.cmd == "wait")
    last_t = records[-1].t if records else 0.0
    total = max(1, int((last_t + waits) * player.rate))
    every = max(1, total // max(frames, 1))
    height = max(1, round(width * header.height / header.width))
    shots: list[np.ndarray] = []

    def shot() -> np.ndarray:
        img = Image.fromarray(to_srgb8(canvas.render()))
        return np.asarray(img.resize((width, height), Image.Resampling.LANCZOS))

    def on_step(p: SessionPlayer) -> None:
        if p.counters.steps % every == 0:
            shots.append(shot())

    shots.append(shot())
    player.play(records, on_step=on_step)
    shots.append(shot())
    if final is not None:

        final(canvas, get_profile(player.profile).renderer)
    close = getattr(canvas, "close", None)
    if close is not None:
        close()
    yield from shots


def export_replay(log_path: str | os.PathLike[str], out: str | os.PathLike[str],
                  frames: int = 48, width: int = 400, frame_ms: int = 80,
                  hold_ms: int = 2000, final: Callable[[Any, str], None] | None = None
                  ) -> int:
    """Write the replay of a session log as an animated WebP or GIF (by suffix);
    returns the number of frames.  The last frame (the painting) is held.  ``final``:
    see :func:`replay_frames`."""
    from PIL import Image

    arrays: list[np.ndarray] = []
    durations: list[int] = []
    for f in replay_frames(log_path, frames, width, final=final):
        if arrays and np.array_equal(arrays[-1], f):  # nothing changed: show it longer
            durations[-1] += frame_ms
        else:
            arrays.append(f)
            durations.append(frame_ms)
    durations[-1] = max(durations[-1], hold_ms)
    imgs = [Image.fromarray(a) for a in arrays]
    out = Path(out)
    tmp = out.with_name(out.name + ".tmp")
    fmt = "GIF" if out.suffix.lower() == ".gif" else "WEBP"
    extra: dict[str, Any] = {"lossless": False, "quality": 85} if fmt == "WEBP" else {}
    imgs[0].save(tmp, format=fmt, save_all=True, append_images=imgs[1:], duration=durations,
                 loop=0, **extra)
    os.replace(tmp, out)
    return len(imgs)

