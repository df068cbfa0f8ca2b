"""Force feedback from the simulation: the deformable brush's reaction on ``haptic.<device>``.

While the active brush is deformable, as the simulation paints a haptic
device's pen sample (at most ``max_rate_hz`` times a second per device) it
solves the tuft at that sample's pose (the painting brush's own
pressure/tilt mapping, plastic state from its spines, just updated by the
sample) and publishes the canvas's reaction as a
:class:`~station.wire.HapticForce` (N) on ``haptic.<device>``; the device's
driver (``contact=bus``) interpolates the frames to its 1 kHz loop, adds
friction and paper grain, and passes the sum through its safety layer
(docs/haptic-protocol.md §8).  Frames follow the samples, not the sim steps:
a sim behind on a burst of samples (it paints up to 2000 between two steps)
still sends them.  A device in proximity but off the paper gets zero frames
(the driver's part goes to zero at once instead of waiting for its watchdog).
With the round brush nothing is published: the driver's own spring is that
brush's force.

Only devices for which ``wanted(name)`` is true cost a solve: ``station sim``
and the kiosk ask their publisher whether a subscriber holds
``haptic.<device>`` (a haptic driver does; :meth:`station.bus.Publisher.wants`).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable

from station.brush.deformable import DeformableBrush
from station.brush.stamp import RoundBrush
from station.drivers.haptic.deformable import SimReaction
from station.events import PenSample
from station.wire import HapticForce

log = logging.getLogger(__name__)

MAX_RATE_HZ = 40.0


class HapticFeedback:
    """Computes and sends the reaction frames (see the module docstring).

    ``send(device, force)`` publishes one frame; ``wanted(device)``: whether anyone
    renders that device's forces (default: nobody); ``clock`` paces the frames.
    """

    def __init__(self, send: Callable[[str, HapticForce], object],
                 wanted: Callable[[str], bool] | None = None,
                 max_rate_hz: float = MAX_RATE_HZ,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.send = send
        self.wanted: Callable[[str], bool] = wanted or (lambda name: False)
        self.period = 1.0 / max_rate_hz
        self.clock = clock
        self.reaction = SimReaction()
        self.frames = 0
        self.errors = 0
        self.seconds = 0.0
        self._next: dict[str, float] = {}

    def on_sample(self, brush: RoundBrush | DeformableBrush, sample: PenSample,
                  t: float) -> bool:
        """A sample was painted: send its device's frame if due (deformable brush, in
        proximity, someone renders it); ``t``: the session time stamped on it."""
        if not isinstance(brush, DeformableBrush) or not sample.proximity:
            return False
        name = sample.device
        now = self.clock()
        if now < self._next.get(name, -math.inf) or not self.wanted(name):
            return False
        self._next[name] = now + self.period
        t0 = time.perf_counter()
        try:
            fx, fy, fz = self.reaction.force(brush, sample)
            self.send(name, HapticForce(max(0.0, t), fx, fy, fz))
        except Exception as exc:  # never let feedback stop the painting
            self.errors += 1
            if self.errors <= 3:
                log.warning("haptic feedback for %s failed: %s", name, exc)
            return False
        finally:
            self.seconds += time.perf_counter() - t0
        self.frames += 1
        return True

    def as_dict(self) -> dict[str, float]:
        return {"frames": self.frames, "errors": self.errors,
                "ms_per_frame": round(1e3 * self.seconds / max(1, self.frames), 3)}
