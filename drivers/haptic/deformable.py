"""Force from the deformable brush: the reaction of the canvas on the deformed tuft.

The deformable brush's bristles are spines in static equilibrium under the
paper (``station.brush.solver``: NLopt SLSQP, the paper as constraints
``z_j ≥ 0``, docs/brush.md).  The canvas pushes back on the handle with minus
the gradient of the tuft's equilibrium spring energy ``E*(h)`` with respect to
the handle position ``h``.  By the envelope theorem that gradient is the
partial derivative of the Lagrangian at the solved shape: the springs do not
depend on ``h`` (their angles are relative to the handle), the constraints do
(``z_j = h_z + …``), so

    ∂E*/∂h = -Σ_j λ_j ∂z_j/∂h = -(0, 0, Σ_j λ_j)

with ``λ_j ≥ 0`` the multipliers of the joints lying on the paper: the
contact forces, which sum to the canvas's reaction (:func:`multipliers`
recovers them from the KKT conditions ``∇E = Σ λ_j ∇z_j`` by least squares;
tests hold them against a finite difference of ``E*``).  On
flat frictionless paper the lateral gradient is exactly zero: sideways the
canvas reacts only through friction, which is Coulomb friction ``μ·F_n``
opposing the stroke (and the paper's grain as a vibration), rendered at the
haptic rate by :class:`~station.drivers.haptic.contact.Surface`.

**A function of the pose.**  A buckled tuft has several equilibria under one
pose (it bends one way or curls its tip); warm-starting each frame from the
last one lands on whichever branch the path led to, so a jerky descent felt
up to 60 % stiffer than a smooth one.  Here every evaluation solves from a
canonical start: the spine at its rest shape just touching the paper, pushed
along the handle axis to the pose in steps of at most ``step`` tuft lengths,
each warm-started from the previous one (the smooth descent), tightly
converged.  The result depends on the pose and on the brush's plastic state
(the spines' current rest angles) only.  The force solve is frictionless
(with the canvas's friction inside it the energy would depend on where the
bristles were dragged from, and its gradient would not be a reaction force)
and lets joints lift off the paper (``SpineSolver(hold=False)``: the painting
solve holds a landed joint there, which can come out pulled down, a negative
contact force, and dented the force curve).

Cost: a few SQP solves per spine and evaluation (milliseconds), so it runs at
the simulation rate (30–40 Hz), not in the 1 kHz loop; its forces reach the loop
as timed frames through :class:`~station.drivers.haptic.contact.FrameInterpolator`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from station.drivers.haptic.contact import BrushState, Surface, Vec3

from station.brush.deformable import REACH, DeformableBrush
from station.brush.energy import heights
from station.brush.geometry import BrushShape, get_shape
from station.brush.solver import Friction, SpineSolver, SpineState
from station.brush.spine import SpineSpec, chain
from station.events import PenSample

CONTACT_Z = 1e-5
"""A joint this close to the paper (tuft units) is in contact (as the solver decides)."""


def handle_from_axis(axis: Vec3) -> np.ndarray:
    """The handle's frame (columns X, Y, Z in the canvas frame) with Z along ``axis``."""
    z = np.asarray(axis, np.float64)
    norm = float(np.linalg.norm(z))
    z = z / norm if norm > 1e-9 else np.array([0.0, 0.0, 1.0])
    ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = ref - z * float(ref @ z)
    x /= float(np.linalg.norm(x))
    return np.column_stack([x, np.cross(z, x), z])


def spring_energy(st: SpineState) -> float:
    """The angular spring energy of a solved spine about its current rest (tuft units)."""
    _, stiffness, _ = st.spec.arrays()
    dv = st.x - st.rest
    return float(0.5 * np.sum(np.repeat(stiffness, 2) * dv * dv))


def multipliers(st: SpineState, root: np.ndarray, handle: np.ndarray
                ) -> tuple[np.ndarray, float]:
    """The contact forces ``λ_j`` (n,) of a solved spine and the KKT residual.

    At the equilibrium ``∇E = Σ_{j on paper} λ_j ∇z_j`` over the angles not held
    at their bounds (least squares); the residual is ``|∇E - Σ λ_j ∇z_j| / |∇E|``
    (about 1e-9 at a converged solve).  The solver holds a joint that landed on
    the paper there (an equality, so it drags rather than hops), so a single
    ``λ_j`` can come out negative (the paper holding a joint down) while the sum,
    the handle's force, is the exact derivative of the solved energy.
    """
    lengths, stiffness, _ = st.spec.arrays()
    n = st.spec.n
    zg = np.empty((n, 2 * n))
    z = heights(st.x, zg, lengths, root, handle)
    grad = np.repeat(stiffness, 2) * (st.x - st.rest)
    lo, hi = st.spec.bounds()
    free = (st.x > lo + 1e-7) & (st.x < hi - 1e-7)
    on = np.flatnonzero(z <= CONTACT_Z)
    lam = np.zeros(n)
    if on.size == 0 or not free.any():
        return lam, 0.0
    a = zg[on][:, free].T
    sol = np.linalg.lstsq(a, grad[free], rcond=None)[0]
    lam[on] = sol
    rnorm = float(np.linalg.norm(a @ sol - grad[free]))
    return lam, rnorm / max(float(np.linalg.norm(grad[free])), 1e-12)


@dataclass(frozen=True, slots=True)
class Equilibrium:
    """A tuft solved at one handle pose (tuft units).

    Attributes:
        energy: total spring energy, each of the K spines weighted ``1/K``.
        gradient: ``dE*/dh`` (3,), the energy's gradient in the handle position.
        lam: per spine, its joints' contact forces (n,).
        residual: the largest KKT residual of the spines.
        states: the solved spines.
    """

    energy: float
    gradient: np.ndarray
    lam: tuple[np.ndarray, ...]
    residual: float
    states: tuple[SpineState, ...]


@dataclass
class TuftReaction:
    """Solves a tuft of spines at a handle pose from the canonical start (module docstring).

    Attributes:
        step: largest height step of the canonical descent, tuft lengths.
        solver: frictionless SQP, converged tighter than the painting brush's.
    """

    step: float = 0.04
    solver: SpineSolver = field(default_factory=lambda: SpineSolver(
        friction=Friction(mu_n=0.0), max_evals=500, xtol=1e-9, hold=False))

    def solve(self, specs: Sequence[SpineSpec], roots: np.ndarray, handle: np.ndarray,
              rests: Sequence[np.ndarray] | None = None) -> Equilibrium:
        """The equilibrium with spine ``k`` rooted at ``roots[k]`` (K, 3), the handle frame
        ``handle`` (3, 3), and rest angles ``rests[k]`` (default: the specs' own)."""
        handle = np.ascontiguousarray(handle, np.float64)
        up = handle[:, 2]
        weight = 1.0 / len(specs)
        energy = 0.0
        lift = 0.0
        worst = 0.0
        lams: list[np.ndarray] = []
        states: list[SpineState] = []
        for k, spec in enumerate(specs):
            root = np.asarray(roots[k], np.float64)
            rest = (np.asarray(spec.rest, np.float64) if rests is None
                    else np.asarray(rests[k], np.float64))
            st = SpineState(spec, rest.copy(), rest.copy())
            pos, _, _ = chain(st.x, spec.arrays()[0], root, handle)
            depth = -float(pos[:, 2].min())  # below the touch-down height, along z
            if depth <= 0.0 or up[2] <= 1e-6:
                lams.append(np.zeros(spec.n))
                states.append(st)
                continue
            along = depth / up[2]  # the touch-down root is this far up the handle axis
            steps = max(1, math.ceil(depth / self.step))
            for i in range(1, steps + 1):
                self.solver.solve(st, root + up * (along * (1.0 - i / steps)), handle)
            lam, res = multipliers(st, root, handle)
            energy += weight * spring_energy(st)
            lift += weight * float(lam.sum())
            worst = max(worst, res)
            lams.append(lam)
            states.append(st)
        return Equilibrium(energy, np.array([0.0, 0.0, -lift]), tuple(lams), worst,
                           tuple(states))


@dataclass
class DeformableBrushContact:
    """The deformable brush as a :class:`~station.drivers.haptic.contact.ContactModel`.

    Attributes:
        shape: the brush shape (``station/data/brushes``) whose spines make the tuft.
        tuft_mm: tuft length below the handle tip, mm: one tuft unit of the spine model.
        energy_scale: N·mm per unit of tuft energy: turns the model's dimensionless spring
            energy (springs of ``k ≈ 1`` per rad²) into a felt force; it stands for the
            whole tuft's bristle count and hair modulus.  The default gives about 0.2 N
            a millimetre into the paper and 2 N near a full press of a 6 mm round tuft,
            the range of :class:`~station.drivers.haptic.contact.RoundBrushContact`.
        wall_stiffness: N/mm once the handle tip goes below ``floor_mm`` (the ferrule).
        floor_mm: lowest handle height the spines are solved at, mm.
        surface: friction and paper grain added to the reaction (1 kHz in the loop).
        reaction_model: the equilibrium solver.
    """

    shape: BrushShape = field(default_factory=lambda: get_shape("round3d"))
    tuft_mm: float = 6.0
    energy_scale: float = 6.0
    wall_stiffness: float = 4.0
    floor_mm: float = 0.6
    surface: Surface = field(default_factory=Surface)
    reaction_model: TuftReaction = field(default_factory=TuftReaction)

    def __post_init__(self) -> None:
        self.specs = self.shape.spine_specs()
        self.offsets = self.shape.spine_offsets()
        self.last: Equilibrium | None = None

    def warm_up(self) -> None:
        """One solve in the tuft (loads the compiled solver: the first takes ~1 s)."""
        self.reaction(BrushState(0.0, (0.0, 0.0, 0.5 * self.tuft_mm)))
        self.last = None

    def force_from(self, eq: Equilibrium) -> Vec3:
        """The canvas's reaction on the handle, N, for a solved tuft (tuft units → mm)."""
        g = -eq.gradient * (self.energy_scale / self.tuft_mm)
        return (float(g[0]), float(g[1]), float(g[2]))

    def reaction(self, state: BrushState, rests: Sequence[np.ndarray] | None = None) -> Vec3:
        """The gradient force at the handle, N (no friction, no grain): the sim-rate part.

        ``rests``: the spines' current rest angles (the painting brush's plastic
        state; default the shape's own).
        """
        x, y, z = state.position
        if z >= self.tuft_mm:
            self.last = None
            return (0.0, 0.0, 0.0)
        handle = handle_from_axis(state.axis)
        zs = max(z, self.floor_mm)
        centre = np.array([x, y, zs]) / self.tuft_mm
        roots = centre[None, :] + self.offsets[:, None] * handle[:, 0][None, :]
        eq = self.reaction_model.solve(self.specs, roots, handle, rests)
        self.last = eq
        fx, fy, fz = self.force_from(eq)
        return (fx, fy, fz + self.wall_stiffness * max(0.0, self.floor_mm - z))

    def contact_force(self, state: BrushState) -> Vec3:
        """Reaction plus friction and grain (what the hand feels at this pose)."""
        return self.surface.apply(self.reaction(state), state)


def height_pressure(z_mm: float, tuft_mm: float, press_depth: float) -> float:
    """The pen pressure that puts the simulated brush's handle where the device's is.

    The deformable brush maps pressure ``p`` to the ferrule's height
    ``1 - REACH - press_depth·p`` tuft lengths (``station.brush.deformable``);
    this inverts it for a handle ``z_mm`` above the paper with a ``tuft_mm`` tuft,
    so the force the simulation computes is the one at the device's pose.
    """
    if press_depth <= 0.0 or tuft_mm <= 0.0:
        return 0.0
    return min(1.0, max(0.0, (1.0 - REACH - z_mm / tuft_mm) / press_depth))


@dataclass
class SimReaction:
    """The deformable brush's reaction for a pen sample, as ``station sim`` publishes it.

    The painting brush (:class:`~station.brush.deformable.DeformableBrush`) gives the
    pose (its pressure → height and tilt → handle mapping, in tuft lengths) and the
    plastic state (its spines' current rest angles); the tuft is re-solved from the
    canonical start (:class:`TuftReaction`), so the force does not depend on the
    painting solve's friction or history.

    Attributes:
        tuft_mm: the felt tuft length, mm (one tuft unit), as the driver's ``tuft=``.
        energy_scale: N·mm per unit of tuft energy, as :class:`DeformableBrushContact`.
    """

    tuft_mm: float = 6.0
    energy_scale: float = 6.0
    model: TuftReaction = field(default_factory=TuftReaction)

    def force(self, brush: DeformableBrush, sample: PenSample) -> Vec3:
        """N at the handle (canvas frame; zero when the pen is not on the paper)."""
        if not (sample.touching and sample.proximity):
            return (0.0, 0.0, 0.0)
        roots, handle = brush.pose(sample.x * brush.width, sample.y * brush.height,
                                   sample.pressure, sample.tilt_x, sample.tilt_y,
                                   sample.rotation or 0.0)
        eq = self.model.solve(brush.specs, roots, handle, [st.rest for st in brush.spines])
        g = -eq.gradient * (self.energy_scale / self.tuft_mm)
        return (float(g[0]), float(g[1]), float(g[2]))
