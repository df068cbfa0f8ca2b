"""Force feedback from the simulation: the deformable brush's reaction on ``haptic.<device>``.

While the active brush is deformable, after a sim step (at most
``max_rate_hz`` times a second) the simulation solves the tuft at each
haptic device's newest pen sample (pose from the painting brush's own
pressure/tilt mapping, plastic state from its spines) and publishes the
canvas's reaction as a :class:`~station.wire.HapticForce` (N) on
``haptic.<device>``; the device's driver (``contact=bus``) interpolates the
frames to its 1 kHz loop, adds friction and paper grain, and passes the sum
through its safety layer (docs/haptic-protocol.md §8).  A device in
proximity but off the paper gets zero frames (the driver's part goes to zero
at once instead of waiting for its watchdog).  With the round brush nothing
is published: the driver's own spring is that brush's force.

Haptic devices are those whose name starts with ``haptic-`` (the driver's
default name for a serial haptic device): only they cost a solve.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from typing import Any

from station.brush.deformable import DeformableBrush
from station.drivers.haptic.deformable import SimReaction
from station.wire import HapticForce

log = logging.getLogger(__name__)

PREFIX = "haptic-"
MAX_RATE_HZ = 60.0


class HapticFeedback:
    """Computes and sends the reaction frames (see the module docstring).

    ``send(device, force)`` publishes one frame; ``clock`` paces the frames.
    """

    def __init__(self, send: Callable[[str, HapticForce], object],
                 max_rate_hz: float = MAX_RATE_HZ, prefix: str = PREFIX,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.send = send
        self.period = 1.0 / max_rate_hz
        self.prefix = prefix
        self.clock = clock
        self.reaction = SimReaction()
        self.frames = 0
        self.errors = 0
        self.seconds = 0.0
        self._next = -float("inf")

    def after_step(self, brush: Any, devices: Mapping[str, Any], t: float) -> int:
        """Send a frame per haptic device in proximity (deformable brush only); ``t`` is
        the session time stamped on them.  Returns the number sent."""
        if not isinstance(brush, DeformableBrush):
            return 0
        now = self.clock()
        if now < self._next:
            return 0
        self._next = now + self.period
        sent = 0
        for name, dev in devices.items():
            sample = getattr(dev, "last_sample", None)
            if not name.startswith(self.prefix) or sample is None or not sample.proximity:
                continue
            t0 = time.perf_counter()
            try:
                fx, fy, fz = self.reaction.force(brush, sample)
                self.send(name, HapticForce(max(0.0, t), fx, fy, fz))
            except Exception as exc:  # never let feedback stop the painting
                self.errors += 1
                if self.errors <= 3:
                    log.warning("haptic feedback for %s failed: %s", name, exc)
                continue
            finally:
                self.seconds += time.perf_counter() - t0
            self.frames += 1
            sent += 1
        return sent

    def as_dict(self) -> dict[str, float]:
        return {"frames": self.frames, "errors": self.errors,
                "ms_per_frame": round(1e3 * self.seconds / max(1, self.frames), 3)}
