"""Force from the brush: the canvas's reaction on the brush, felt at the handle.

The haptic loop asks a :class:`ContactModel` for the force at 1 kHz.  Any
brush can be one: it implements ``contact_force(state) -> (fx, fy, fz)``.

* :class:`RoundBrushContact` — the round brush: the hairs are a spring of
  length ``hair_mm`` against the paper, the ferrule a stiff wall below that,
  plus a little Coulomb friction opposing the stroke and the paper's grain as
  a vibration (a deterministic grain field under the tip modulating the
  normal force).  Cheap enough to evaluate on every 1 kHz tick.
* The deformable brush (:class:`drivers.haptic.deformable.DeformableBrushContact`,
  simulated at the sim rate, ~30 Hz, like Baxter's dAb against its 1 kHz
  PHANToM loop) implements ``contact_force`` as the gradient of its spring
  energy at the handle; its forces reach the loop as
  timed frames and :class:`FrameInterpolator` interpolates between them.

The pressure a haptic handle reports as a pen is the normal force through the
same model: ``pressure = min(1, fz / full_force)`` (:func:`pressure_from_force`).

Frames: positions in millimetres in the canvas frame (x right, y toward the
user, z up from the paper surface), velocities in mm/s, forces in newtons.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Protocol

Vec3 = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class BrushState:
    """Where the brush handle is, for a contact model.

    Attributes:
        t: seconds on the station's monotonic clock.
        position: handle tip (the ferrule end, where the hairs start), mm, canvas frame.
        velocity: mm/s, canvas frame.
        axis: unit vector along the handle from the tip toward the top (upright = (0, 0, 1)).
    """

    t: float
    position: Vec3
    velocity: Vec3 = (0.0, 0.0, 0.0)
    axis: Vec3 = (0.0, 0.0, 1.0)


class ContactModel(Protocol):
    """A brush that can say how hard the canvas pushes back on its handle."""

    def contact_force(self, state: BrushState) -> Vec3:
        """The canvas's reaction on the brush at the handle, N (fx, fy, fz), canvas frame."""
        ...


@dataclass(frozen=True)
class RoundBrushContact:
    """The round brush as a spring against the surface (see the module docstring).

    Attributes:
        hair_mm: hair length below the handle tip, mm (contact starts at z < hair_mm).
        stiffness: N/mm of hair compression.
        wall_stiffness: N/mm once the handle tip itself goes below the paper.
        friction: Coulomb coefficient opposing the lateral velocity (0 = off).
        slip_mm_s: below this speed the friction fades in linearly (no stick-slip chatter).
        grain: paper texture as a fraction of the normal force (0 = off).
        grain_mm: size of a paper grain, mm.
    """

    hair_mm: float = 6.0
    stiffness: float = 0.5
    wall_stiffness: float = 4.0
    friction: float = 0.15
    slip_mm_s: float = 5.0
    grain: float = 0.05
    grain_mm: float = 0.4

    def normal_force(self, z_mm: float) -> float:
        """N pushing the handle up when its tip is ``z_mm`` above the paper."""
        depth = self.hair_mm - z_mm
        if depth <= 0.0:
            return 0.0
        return self.stiffness * depth + self.wall_stiffness * max(0.0, -z_mm)

    def contact_force(self, state: BrushState) -> Vec3:
        fn = self.normal_force(state.position[2])
        surface = Surface(self.friction, self.slip_mm_s, self.grain, self.grain_mm)
        return surface.apply((0.0, 0.0, fn), state)


@dataclass(frozen=True)
class Surface:
    """Friction and paper texture on top of a normal force (cheap: 1 kHz).

    Attributes:
        friction: Coulomb coefficient: ``friction · fz`` opposing the lateral velocity.
        slip_mm_s: below this speed the friction fades in linearly (no stick-slip chatter).
        grain: paper texture as a fraction of the normal force (0 = off).
        grain_mm: size of a paper grain, mm.
    """

    friction: float = 0.15
    slip_mm_s: float = 5.0
    grain: float = 0.05
    grain_mm: float = 0.4

    def apply(self, force: Vec3, state: BrushState) -> Vec3:
        """``force`` (N) with the grain modulating its normal part and the friction of
        that normal part added against the stroke; nothing where ``fz <= 0``."""
        fx, fy, fn = force
        if fn <= 0.0:
            return force
        x, y, _ = state.position
        if self.grain:
            fn *= 1.0 + self.grain * paper_grain(x / self.grain_mm, y / self.grain_mm)
        vx, vy, _ = state.velocity
        speed = math.hypot(vx, vy)
        if self.friction and speed > 0.0:
            scale = self.friction * fn * min(1.0, speed / self.slip_mm_s) / speed
            fx, fy = fx - vx * scale, fy - vy * scale
        return (fx, fy, fn)


def paper_grain(u: float, v: float) -> float:
    """A smooth deterministic grain field in [-1, 1] (value noise on a unit lattice)."""
    iu, iv = math.floor(u), math.floor(v)
    fu, fv = u - iu, v - iv
    su, sv = fu * fu * (3 - 2 * fu), fv * fv * (3 - 2 * fv)

    def h(i: int, j: int) -> float:
        n = (i * 374761393 + j * 668265263) & 0xFFFFFFFF
        n = ((n ^ (n >> 13)) * 1274126177) & 0xFFFFFFFF
        return ((n ^ (n >> 16)) & 0xFFFF) / 32767.5 - 1.0

    a = h(iu, iv) + su * (h(iu + 1, iv) - h(iu, iv))
    b = h(iu, iv + 1) + su * (h(iu + 1, iv + 1) - h(iu, iv + 1))
    return a + sv * (b - a)


def pressure_from_force(fz: float, full_force: float) -> float:
    """Pen pressure in [0, 1] from the normal force (N); ``full_force`` N is a full press."""
    if full_force <= 0:
        return 0.0
    return min(1.0, max(0.0, fz / full_force))


class FrameInterpolator:
    """Forces computed at the simulation rate, rendered at the haptic rate.

    ``push(t, force, arrival)`` adds a frame for time ``t`` (the station's
    monotonic clock) that arrived at ``arrival``; ``sample(now)`` renders the
    force at ``now - delay`` by linear interpolation between the two frames
    around it.  ``delay`` is the last frame interval plus how late frames
    arrive (the largest lateness seen, decaying 2 % a frame): one sim frame of
    latency, and a little more on a jittery bus, buy a force without steps (a
    30 Hz staircase is felt as a buzz).  When that target delay changes, the
    delay used follows it at 10 % of real time, so the rendered time never
    jumps.  Before the second frame, and past the newest one, it holds the
    nearest frame.
    """

    def __init__(self) -> None:
        self._frames: list[tuple[float, Vec3]] = []
        self._late = 0.0
        self._delay: float | None = None
        self._now = 0.0

    def push(self, t: float, force: Vec3, arrival: float | None = None) -> None:
        late = 0.0 if arrival is None else max(0.0, arrival - t)
        self._late = max(late, self._late * 0.98)
        if self._frames and t <= self._frames[-1][0]:
            self._frames[-1] = (self._frames[-1][0], force)
            return
        self._frames = [*self._frames[-2:], (t, force)]

    @property
    def last_t(self) -> float | None:
        return self._frames[-1][0] if self._frames else None

    def clear(self) -> None:
        self._frames.clear()
        self._late = 0.0
        self._delay = None

    def sample(self, now: float) -> Vec3:
        frames = self._frames
        if not frames:
            return (0.0, 0.0, 0.0)
        if len(frames) == 1:
            return frames[0][1]
        target = frames[-1][0] - frames[-2][0] + self._late
        if self._delay is None:
            self._delay = target
        else:
            warp = 0.1 * max(0.0, now - self._now)
            self._delay += min(warp, max(-warp, target - self._delay))
        self._now = now
        t = now - self._delay
        for (t0, f0), (t1, f1) in itertools.pairwise(frames):
            if t0 <= t <= t1:
                a = (t - t0) / (t1 - t0)
                return (f0[0] + a * (f1[0] - f0[0]), f0[1] + a * (f1[1] - f0[1]),
                        f0[2] + a * (f1[2] - f0[2]))
        return frames[0][1] if t < frames[0][0] else frames[-1][1]
