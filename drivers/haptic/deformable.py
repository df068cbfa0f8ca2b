"""Force from the deformable brush: the reaction of the canvas at the handle.

The deformable brush's bristles are spines in static equilibrium under the
paper (``station.brush.solver``: NLopt SLSQP with the paper as a constraint,
see docs/brush.md).  The canvas pushes back on the handle with the gradient
of the equilibrium spring energy with respect to the handle position: by the
envelope theorem ``dE*/dp = ∂E/∂p`` at the solved shape, which we take as a
central finite difference of the solved energy in handle ``z``, each probe
warm-started from the previous frame's equilibrium.  The lateral components
are Coulomb friction opposing the stroke, as in
:class:`~drivers.haptic.contact.RoundBrushContact`.

The force depends on the shape the brush carries from frame to frame (the warm
start), as a real tuft's does: past touch-down the single buckled spine has a
force plateau (an elastica's) where frame-to-frame values wobble by a few per
cent, and a jerky stroke can land on a stiffer buckled branch than a smooth one.

One evaluation is three SQP solves (about 1 ms): it runs at the simulation rate (~30 Hz),
not in the 1 kHz loop; its forces reach the loop as timed frames through
:class:`~drivers.haptic.contact.FrameInterpolator`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from drivers.haptic.contact import BrushState, Vec3
from station.brush.solver import Friction, SpineSolver, SpineState
from station.brush.spine import SpineSpec


def _handle(axis: Vec3) -> np.ndarray:
    """The handle's frame (columns X, Y, Z in the canvas frame) with Z along ``axis``."""
    z = np.asarray(axis, np.float64)
    norm = float(np.linalg.norm(z))
    z = z / norm if norm > 1e-9 else np.array([0.0, 0.0, 1.0])
    ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = ref - z * float(ref @ z)
    x /= float(np.linalg.norm(x))
    return np.column_stack([x, np.cross(z, x), z])


def _copy(st: SpineState) -> SpineState:
    return SpineState(st.spec, st.x.copy(), st.rest.copy(), st.pos, st.contact, st.root)


def spring_energy(st: SpineState) -> float:
    """The angular spring energy of a solved spine, energy per unit tuft (dimensionless)."""
    _, stiffness, _ = st.spec.arrays()
    dv = st.x - st.rest
    return float(0.5 * np.sum(np.repeat(stiffness, 2) * dv * dv))


@dataclass
class DeformableBrushContact:
    """The deformable brush as a :class:`~drivers.haptic.contact.ContactModel`.

    Attributes:
        tuft_mm: tuft length below the handle tip, mm (contact starts at z < tuft_mm);
            one tuft unit of the spine model is this many mm.
        energy_scale: N·mm per unit of spine energy: the stiffness scale that turns the
            model's dimensionless spring energy (springs of ``k ≈ 1`` per rad²) into a
            felt force; it stands for the whole tuft's bristle count and hair modulus.
            The default gives about 0.4 N at a light touch and 2.5 N with the handle
            0.8 mm above the paper (6 mm tuft), the range of
            :class:`~drivers.haptic.contact.RoundBrushContact`.
        wall_stiffness: N/mm once the handle tip goes below ``floor_mm`` (the ferrule).
        floor_mm: lowest handle height the spines are solved at, mm.
        step_mm: finite-difference step in handle z, mm (wide enough to step over
            the kinks where a joint touches down).
        friction: Coulomb coefficient opposing the lateral velocity (0 = off).
        slip_mm_s: below this speed the friction fades in linearly.
        spec: the spine's make-up (one representative spine of the tuft).
        solver: the spines' SQP solver.  Frictionless by default: with the canvas's
            dissipative friction inside the solve the spring energy depends on the
            path, not only on the handle, and its gradient is no reaction force; the
            friction is felt through ``friction`` instead.
    """

    tuft_mm: float = 6.0
    energy_scale: float = 6.0
    wall_stiffness: float = 4.0
    floor_mm: float = 0.6
    step_mm: float = 0.2
    friction: float = 0.15
    slip_mm_s: float = 5.0
    spec: SpineSpec = field(default_factory=SpineSpec.tapered)
    solver: SpineSolver = field(default_factory=lambda: SpineSolver(friction=Friction(mu_n=0.0)))

    def __post_init__(self) -> None:
        self._state = SpineState.at_rest(self.spec)

    def reset(self) -> None:
        """Forget the last shape (the brush left the paper)."""
        self._state = SpineState.at_rest(self.spec)

    def _energy(self, st: SpineState, x: float, y: float, z: float, handle: np.ndarray
                ) -> float:
        root = np.array([x, y, z]) / self.tuft_mm
        self.solver.solve(st, root, handle)
        return self.energy_scale * spring_energy(st)

    def normal_force(self, state: BrushState) -> float:
        """N pushing the handle up (along canvas z); advances the warm-start shape."""
        x, y, z = state.position
        if z >= self.tuft_mm:
            self.reset()
            return 0.0
        handle = _handle(state.axis)
        zs = max(z, self.floor_mm)
        h = self.step_mm
        # the frame's own equilibrium first (the next frame's warm start), then both
        # probes from it, so all three lie on the same branch of the buckled tuft
        self._energy(self._state, x, y, zs, handle)
        e_hi = self._energy(_copy(self._state), x, y, zs + h, handle)
        e_lo = self._energy(_copy(self._state), x, y, zs - h, handle)
        fn = max(0.0, -(e_hi - e_lo) / (2.0 * h))
        return fn + self.wall_stiffness * max(0.0, self.floor_mm - z)

    def contact_force(self, state: BrushState) -> Vec3:
        fn = self.normal_force(state)
        if fn == 0.0:
            return (0.0, 0.0, 0.0)
        fx = fy = 0.0
        vx, vy, _ = state.velocity
        speed = math.hypot(vx, vy)
        if self.friction and speed > 0.0:
            scale = self.friction * fn * min(1.0, speed / self.slip_mm_s) / speed
            fx, fy = -vx * scale, -vy * scale
        return (fx, fy, fn)
