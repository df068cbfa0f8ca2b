"""Static equilibrium of a spine per frame with NLopt's SLSQP (dissertation §7.3.4).

The dissertation minimised the energy with donlp2 (an SQP code); NLopt's SLSQP
is the same method with a binary wheel.  Each frame:

1. *Predict*: the last frame's angles at the new root and handle pose.
2. *Contact set*: joints whose predicted height is at or below the plane
   (joints that lay on the canvas and are still pushed onto it stay; joints the
   handle lifted clear leave it).  A joint touching down this frame gets the
   crossing point of its last → predicted path as its anchor (fig. 7.4); a joint
   that lay on the canvas keeps its last position.
3. *Solve* from the last angles (warm start) with analytic gradients: equality
   ``z_j = 0`` for the contact set, ``z_j ≥ 0`` for the others, ``|θ| ≤ 80°``.
4. *Accept* a finite result that keeps every joint above ``-TOL``; otherwise
   keep the last shape and count a fallback.  The budget is an evaluation
   count (deterministic, so a replay gives the same brush) plus, in live use
   only, a wall-clock limit (``time_budget_s``: a compiled solve that took longer
   counts as failed, and NLopt gets it as its own limit).

Step 3 runs :func:`station.brush.sqp.sqp` (the same method compiled, no call
back into Python: issue 26); a frame it declines (an infeasible linearisation,
no descent, budget) goes to NLopt, whose SLSQP relaxes infeasible subproblems.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import nlopt
import numpy as np

from station.brush.energy import evaluate, heights
from station.brush.spine import SpineSpec, chain
from station.brush.sqp import OK, solve_frame

TOL = 1e-6
"""Largest accepted penetration of a joint below the plane, tuft units."""
CONTACT_TOL = 1e-7
SUBSTEPS = 4
BUCKLE = 0.05
"""Bend (rad per joint) given to a straight spine pressed onto the canvas."""
SET_DOWN_BEND = 0.25
"""Bend [rad per joint] behind the pen's first move that a tuft with a straight spine (a
fan) is set down with (:func:`bend_behind`). Bending only the straight spine by ``BUCKLE``
left a diagonal stroke 1.9 cells off its line on average (the trailing outer spine held out
to the side); 0.15 on every spine 0.9; 0.25 0.3-0.4, its rows within 1.4 cells (a
diagonal's half cells). More narrows the fan's mark (0.3: 22 cells wide pulled down)."""
FTOL = 1e-12
"""Absolute tolerance on the energy between two iterates."""
CTOL = 1e-9
"""How far (tuft units) a height may miss its constraint at a feasible point."""
METHODS = ("sqp", "nlopt")
_NO_POS = np.zeros((0, 3))
_NO_CONTACT = np.zeros(0, np.bool_)


@dataclass(frozen=True, slots=True)
class Friction:
    """Friction constants (energy per tuft unit of drag).

    Attributes:
        mu_n: kinetic friction coefficient times the (constant per frame) normal
            force of a joint in contact.
        c_eta: anisotropy ``Cη`` in [0, 1]: the share of the friction removed
            when the joint is pulled straight behind its parent.
        k_eta: exponent ``k`` of the anisotropic cone.
    """

    mu_n: float = 0.35
    c_eta: float = 0.8
    k_eta: float = 2.0


@dataclass(slots=True)
class SpineState:
    """What one spine carries from frame to frame."""

    spec: SpineSpec
    x: np.ndarray  # angles (2n,)
    rest: np.ndarray  # current rest angles (plasticity moves them)
    pos: np.ndarray | None = None  # joints (n, 3) last frame
    contact: np.ndarray | None = None  # (n,) bool last frame
    root: np.ndarray | None = None  # root (3,) last frame

    @classmethod
    def at_rest(cls, spec: SpineSpec) -> SpineState:
        _, _, rest = spec.arrays()
        return cls(spec, rest.copy(), rest.copy())


@dataclass(slots=True)
class SolverCounters:
    """Per-solver bookkeeping (``station bench brush`` reads it)."""

    solves: int = 0
    fallbacks: int = 0
    evaluations: int = 0
    seconds: float = 0.0  # wall clock
    cpu_seconds: float = 0.0  # this thread's CPU time (what a shared machine leaves us)
    compiled_declined: int = 0  # tries the compiled SQP gave to NLopt

    def as_dict(self) -> dict[str, float]:
        return {"solves": self.solves, "fallbacks": self.fallbacks,
                "compiled_declined": self.compiled_declined,
                "evaluations": self.evaluations, "seconds": round(self.seconds, 6),
                "cpu_seconds": round(self.cpu_seconds, 6)}


@dataclass
class SpineSolver:
    """Finds each frame's equilibrium of a spine (see the module docstring).

    Attributes:
        friction: the friction constants.
        max_evals: evaluation budget per frame (deterministic).
        time_budget_s: wall-clock budget per frame, or ``None`` (replays).
        xtol: relative tolerance on the angles.
        hold: hold the joints that lie on the canvas there (an equality: they drag
            instead of hopping off to escape their friction; the painting brush).
            ``False``: every joint only stays above the canvas and may lift off (a
            frictionless tuft whose contact forces are all pushes: the haptic reaction).
        method: ``"sqp"``: the compiled SQP of :mod:`station.brush.sqp` (one numba
            call a frame), NLopt's SLSQP where it declines a frame; ``"nlopt"``:
            NLopt only (the path before issue 26; the bench's comparison).
    """

    friction: Friction = field(default_factory=Friction)
    max_evals: int = 200
    time_budget_s: float | None = None
    xtol: float = 1e-6
    counters: SolverCounters = field(default_factory=SolverCounters)
    hold: bool = True
    method: str = "sqp"

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"solver method {self.method!r} is not one of {', '.join(METHODS)}")

    def solve(self, st: SpineState, root: np.ndarray, handle: np.ndarray) -> np.ndarray:
        """Move ``st`` to its equilibrium at ``root`` (3,), ``handle`` (3, 3); joints (n, 3).

        A frame SQP cannot solve from the last shape (typically a touch-down
        straight into deep pressure) is retried by continuation: the root
        approaches from where it was (from just above the canvas for a new
        stroke) in ``SUBSTEPS`` steps.  Only when that fails too is the last
        shape kept and a fallback counted.
        """
        t0, c0 = time.perf_counter(), time.thread_time()
        root = np.ascontiguousarray(root, np.float64)
        handle = np.ascontiguousarray(handle, np.float64)
        saved = (st.x.copy(), st.pos, st.contact, st.root)
        ok = self._solve(st, root, handle)
        if not ok:
            st.x, st.pos, st.contact, st.root = saved
            start = st.root if st.root is not None else root + handle[:, 2] * (
                1.0 - root[2]) / max(handle[2, 2], 0.2)
            for k in range(1, SUBSTEPS + 1):
                ok = self._solve(st, start + (root - start) * (k / SUBSTEPS), handle)
                if not ok:
                    break
        self.counters.solves += 1
        if not ok:
            self.counters.fallbacks += 1
            st.x, st.pos, st.contact, st.root = saved
            pos, _, _ = chain(st.x, st.spec.arrays()[0], root, handle)
            st.pos, st.root = pos, root
            st.contact = pos[:, 2] <= 1e-5
        self.counters.seconds += time.perf_counter() - t0
        self.counters.cpu_seconds += time.thread_time() - c0
        return st.pos if st.pos is not None else np.zeros((st.spec.n, 3))

    def _solve(self, st: SpineState, root: np.ndarray, handle: np.ndarray) -> bool:
        lengths, stiffness, lo, hi = _arrays(st.spec)
        n = lengths.shape[0]
        anchor = np.empty((n, 2))
        pull = np.empty((n, 2))
        cflt = np.empty(n)
        x0 = np.empty(2 * n)
        stats = np.zeros(3, np.int64)
        last_pos = st.pos if st.pos is not None and st.contact is not None else _NO_POS
        last_contact = st.contact if st.pos is not None and st.contact is not None \
            else _NO_CONTACT
        has_last = last_pos is not _NO_POS
        fr = self.friction
        # one compiled call: contact set, anchors, warm start (steps 1-2) and the SQP
        t0 = time.perf_counter()
        status = solve_frame(st.x, lo, hi, lengths, stiffness, st.rest, root, handle,
                             last_pos, last_contact, has_last, self.hold,
                             CONTACT_TOL, BUCKLE, fr.mu_n, fr.c_eta, fr.k_eta,
                             self.max_evals if self.method == "sqp" else 0, self.xtol, FTOL,
                             CTOL, x0, anchor, pull, cflt, stats)
        if self.method == "sqp":
            self.counters.evaluations += int(stats[0])
        x: np.ndarray | None = None
        budget = self.time_budget_s
        if budget is not None and time.perf_counter() - t0 > budget:
            return False  # over the live budget, as NLopt's MAXTIME_REACHED
        if status == OK:  # a feasible point: its heights within CTOL < TOL
            x = x0
        else:  # NLopt's SLSQP relaxes what the compiled one gives up on
            if self.method == "sqp":
                self.counters.compiled_declined += 1
            x = self._nlopt(x0, lo, hi, lengths, stiffness, st.rest, root, handle, cflt,
                            anchor, pull, fr.mu_n * cflt)
        if x is None:
            return False
        pos, _, _ = chain(x, lengths, root, handle)
        st.x = x
        st.pos = pos
        st.root = root
        st.contact = pos[:, 2] <= 1e-5
        return True

    def _nlopt(self, x0: np.ndarray, lo: np.ndarray, hi: np.ndarray, lengths: np.ndarray,
               stiffness: np.ndarray, rest: np.ndarray, root: np.ndarray, handle: np.ndarray,
               cflt: np.ndarray, anchor: np.ndarray, pull: np.ndarray, mu_n: np.ndarray
               ) -> np.ndarray | None:
        """The frame's solve with NLopt's SLSQP (the path before issue 26, and the
        fallback of the compiled one): the angles, or ``None``."""
        n = lengths.shape[0]
        fr = self.friction
        contact = cflt > 0.0
        evals = [0]
        eq = np.flatnonzero(contact)
        free = np.flatnonzero(~contact)
        # one numba call per SQP iterate fills all three callbacks (NLopt asks for the
        # objective and then the constraints at the same x)
        cache = [b""]
        g = np.empty(2 * n)
        z = np.empty(n)
        zg = np.empty((n, 2 * n))
        e_val = [0.0]

        def at(x: np.ndarray) -> None:
            key = x.tobytes()
            if key != cache[0]:
                e_val[0] = evaluate(x, g, z, zg, lengths, stiffness, rest, root, handle, cflt,
                                    anchor, pull, mu_n, fr.c_eta, fr.k_eta)
                cache[0] = key

        def objective(x: np.ndarray, grad: np.ndarray) -> float:
            evals[0] += 1
            at(x)
            if grad.size:
                grad[:] = g
            return float(e_val[0])

        def eq_c(result: np.ndarray, x: np.ndarray, grad: np.ndarray) -> None:
            at(x)
            result[:] = z[eq]
            if grad.size:
                grad[:] = zg[eq]

        def ineq_c(result: np.ndarray, x: np.ndarray, grad: np.ndarray) -> None:
            at(x)
            result[:] = -z[free]  # NLopt wants c(x) <= 0
            if grad.size:
                grad[:] = -zg[free]

        opt = nlopt.opt(nlopt.LD_SLSQP, 2 * n)
        opt.set_lower_bounds(lo)
        opt.set_upper_bounds(hi)
        opt.set_min_objective(objective)
        if eq.size:
            opt.add_equality_mconstraint(eq_c, np.full(eq.size, CTOL))
        if free.size:
            opt.add_inequality_mconstraint(ineq_c, np.full(free.size, CTOL))
        opt.set_xtol_rel(self.xtol)
        opt.set_ftol_abs(FTOL)
        opt.set_maxeval(self.max_evals)
        if self.time_budget_s is not None:
            opt.set_maxtime(self.time_budget_s)
        ok = True
        try:
            x = opt.optimize(x0)
        except (nlopt.RoundoffLimited, RuntimeError, ValueError):
            x = None
            ok = False
        if ok and x is not None:
            ok = bool(np.isfinite(x).all()) and _acceptable(x, lengths, root, handle, cflt)
            if ok and opt.last_optimize_result() == nlopt.MAXTIME_REACHED:
                ok = False
        self.counters.evaluations += evals[0]
        return np.asarray(x, np.float64) if ok and x is not None else None


def has_straight(specs: list[SpineSpec]) -> bool:
    """Does a tuft of ``specs`` have a straight spine (a fan's middle one)?  Pressed, it
    buckles the solver's default way (across the handle's X) unless set bending first.
    The shape's rest, not the plastic set a last stroke left."""
    return any(max(map(abs, spec.rest), default=0.0) < BUCKLE for spec in specs)


def bend_behind(states: list[SpineState], specs: list[SpineSpec], handle: np.ndarray,
                dx: float, dy: float) -> None:
    """Set a tuft down bending behind the pen's first move (``dx, dy`` cells; ``handle``
    the handle's frame): every spine starts ``SET_DOWN_BEND`` back from its shape's rest,
    and the next solve goes on from there. Pressed straight down, a fan's middle spine
    buckled the solver's default way (across the fan's width) and the stroke pulled down
    sat 1.7 cells off the pen's line; set down splayed flat, a diagonal stroke's trailing
    outer spine stayed out to the side (friction holds it) for a tuft length or two, 2-4
    cells off. A painter's hairs trail the motion."""
    hx = dx * handle[0, 0] + dy * handle[1, 0]  # the motion along the handle's X, Y
    hy = dx * handle[0, 1] + dy * handle[1, 1]
    big = max(abs(hx), abs(hy))
    if big <= 0.0:
        return
    # theta > 0 bends a segment toward the handle's +Y, phi > 0 toward its -X
    theta, phi = -SET_DOWN_BEND * hy / big, SET_DOWN_BEND * hx / big
    for st, spec in zip(states, specs, strict=True):
        st.x = np.asarray(spec.rest, np.float64)
        st.x[0::2] += theta
        st.x[1::2] += phi
        st.pos, st.contact = None, None


@functools.lru_cache(maxsize=256)
def _arrays(spec: SpineSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Lengths, stiffness and the angle bounds of ``spec``, shared: never written (a
    frame's solve would spend as long building them as the compiled SQP takes; left
    writeable so that numba sees the same array types as everywhere else)."""
    lengths, stiffness, _ = spec.arrays()
    lo, hi = spec.bounds()
    return lengths, stiffness, lo, hi


def _acceptable(x: np.ndarray, lengths: np.ndarray, root: np.ndarray, handle: np.ndarray,
                cflt: np.ndarray) -> bool:
    """Step 4: every joint above ``-TOL`` and the held ones within 1e-5 of the plane."""
    if not np.isfinite(x).all():
        return False
    z = heights(x, np.empty((0, 0)), lengths, root, handle)
    held = cflt > 0.0
    return bool(z.min() >= -TOL and (not held.any() or np.abs(z[held]).max() <= 1e-5))
