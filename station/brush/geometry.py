"""Brush shapes (data files) and the tuft's free-form deformation (§7.4).

A shape file (``station/data/brushes/<name>.json``, validated against
``schema.json``) gives the spines' mechanics and the tuft: bristle count,
bristle width, the lateral profile along the tuft, the ferrule's width and
thickness.  Lengths are in tuft units (the spine is 1 long); ``length`` scales
the tuft to the brush ``size`` in cells.

Deformation (Sederberg–Parry FFD, as the dissertation's vertex shader, table
7.1): each bristle is a polyline of points with lattice coordinates
``(s, t, u)`` in ``[0,1]³`` (``u`` along the tuft, ``s`` across, ``t``
through its thickness).  The lattice has ``n+1`` layers along ``u`` (the
root and the ``n`` joints of the spines), ``A`` nodes across and 2 through:

* one spine (round, rigger, mop, calligraphy): ``A = 2``; the nodes of layer
  ``m`` sit at the spine's joint ``m`` ± the radius along the segment frame's
  X and Y axes, so the lattice follows the spine's bend and twist;
* ``K ≥ 2`` spines (flat, fan): ``A = K``, node ``a`` of a layer sits on spine
  ``a`` (± half the thickness along its frame's Y): each spine drives one side
  of the lattice (fig. 7.6) and a flat brush spreads when its spines do.

A point's position is ``Σ B_a(s) B_b(t) B_m(u) P[a,b,m]`` with Bernstein
polynomials ``B``; the weights of every bristle point are computed once, so
deforming the tuft is one matrix product.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import jsonschema
import numba
import numpy as np

from station import boundedio
from station.brush.solver import Friction, SpineState
from station.brush.spine import SpineSpec, chain
from station.errors import BadInput

SAMPLES = 8
"""Points per bristle polyline (root to tip)."""
RETENTION_SPREAD = 0.3
"""Log-normal spread of the locks' ink retention (and 0.3 of it per bristle)."""
BRISTLES_PER_LOCK = 12
"""Bristles a drying tuft draws into one lock (its clumps)."""
RETENTION_RIM = 0.4
"""How much more of its ink the core keeps than the rim (per unit of radius)."""


class BrushShapeError(BadInput):
    """A brush shape file is unreadable or breaks the schema."""


@cache
def _schema() -> dict[str, Any]:
    text = resources.files("station.data").joinpath("brushes/schema.json").read_text()
    return dict(json.loads(text))


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


@dataclass(frozen=True, slots=True)
class BrushShape:
    """One brush shape (see the module docstring and ``schema.json``)."""

    name: str
    description: str
    spines: int
    segments: int
    taper: float
    stiffness: float
    soften: float
    splay_deg: float
    length: float
    radius: float
    width: float
    thickness: float
    profile: tuple[tuple[float, float], ...]
    bristles: int
    bristle_width: float
    tip_spread: float
    friction: Friction
    press_depth: float
    capacity: float
    pickup: float
    plasticity: float
    recovery: float
    seed: int
    spread: float = 0.0
    layout: str = "random"

    @classmethod
    def from_dict(cls, data: Any, where: str | None = None) -> BrushShape:
        try:
            jsonschema.validate(data, _schema())
        except jsonschema.ValidationError as exc:
            path = "/".join(str(p) for p in exc.absolute_path) or "top level"
            raise BrushShapeError(f"brush shape {path}: {exc.message}", where) from None
        prof = tuple((float(u), float(w)) for u, w in data.get("profile", [[0, 1], [1, 1]]))
        if any(b[0] <= a[0] for a, b in itertools.pairwise(prof)):
            raise BrushShapeError("brush shape profile: u must increase", where)
        if prof[0][0] != 0.0 or prof[-1][0] != 1.0:
            raise BrushShapeError("brush shape profile must run from u=0 to u=1", where)
        fr = data.get("friction", {})
        k = int(data["spines"])
        if k >= 2 and "width" not in data:
            raise BrushShapeError("a brush with several spines needs a width", where)
        return cls(
            name=str(data["name"]), description=str(data.get("description", "")),
            spines=k, segments=int(data["segments"]),
            taper=float(data.get("taper", 0.75)), stiffness=float(data.get("stiffness", 1.0)),
            soften=float(data.get("soften", 0.6)), splay_deg=float(data.get("splay_deg", 0.0)),
            length=float(data["length"]), radius=float(data.get("radius", 0.2)),
            width=float(data.get("width", 0.0)), thickness=float(data.get("thickness", 0.1)),
            profile=prof, bristles=int(data["bristles"]),
            bristle_width=float(data.get("bristle_width", 0.04)),
            tip_spread=float(data.get("tip_spread", 0.1)),
            friction=Friction(float(fr.get("mu_n", 0.35)), float(fr.get("c_eta", 0.8)),
                              float(fr.get("k_eta", 2.0))),
            press_depth=float(data.get("press_depth", 0.7)),
            capacity=float(data.get("capacity", 50.0)), pickup=float(data.get("pickup", 0.25)),
            plasticity=float(data.get("plasticity", 0.02)),
            recovery=float(data.get("recovery", 0.3)), seed=int(data.get("seed", 0)),
            spread=float(data.get("spread", 0.0)), layout=str(data.get("layout", "random")))

    @classmethod
    def load(cls, path: str | Path) -> BrushShape:
        where = str(path)
        try:
            text = boundedio.read_text(path, boundedio.CAP_CONFIG, where)
        except FileNotFoundError:
            raise BrushShapeError("no such brush shape file", where) from None
        except (OSError, UnicodeDecodeError) as exc:
            raise BrushShapeError(f"cannot read brush shape ({exc.__class__.__name__})",
                                  where) from None
        return cls.loads(text, where)

    @classmethod
    def loads(cls, text: str, where: str) -> BrushShape:
        """A brush shape from its JSON text (NaN and Infinity are not JSON numbers)."""
        try:
            data = json.loads(text, parse_constant=_no_constant)
        except json.JSONDecodeError as exc:
            raise BrushShapeError(f"not JSON (line {exc.lineno}: {exc.msg})", where) from None
        except ValueError as exc:
            raise BrushShapeError(f"not JSON ({exc})", where) from None
        except RecursionError:  # "[[[[…": the decoder recurses per level
            raise BrushShapeError("not JSON (nested too deeply)", where) from None
        return cls.from_dict(data, where)

    def spine_specs(self) -> list[SpineSpec]:
        """One spec per spine; outer spines of a multi-spine brush lean outward by ``splay``."""
        specs = []
        for k in range(self.spines):
            side = 0.0 if self.spines == 1 else 2.0 * k / (self.spines - 1) - 1.0
            # spreading across (the handle's X) is a rotation about Y: φ
            splay = (0.0, -math.radians(self.splay_deg) * side)
            specs.append(SpineSpec.tapered(self.segments, self.taper, self.stiffness,
                                           self.soften, splay))
        return specs

    def spine_offsets(self) -> np.ndarray:
        """Root offsets of the spines along the handle's X axis, tuft units (K,)."""
        if self.spines == 1:
            return np.zeros(1)
        return (np.linspace(-0.5, 0.5, self.spines) * self.width).astype(np.float64)


@cache
def builtin_shapes() -> dict[str, BrushShape]:
    """The shapes shipped in ``station/data/brushes`` by name."""
    out: dict[str, BrushShape] = {}
    folder = resources.files("station.data").joinpath("brushes")
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(".json") and entry.name != "schema.json":
            data = json.loads(entry.read_text())
            shape = BrushShape.from_dict(data, f"station/data/brushes/{entry.name}")
            out[shape.name] = shape
    return out


_REGISTERED: dict[str, BrushShape] = {}


def register_shape(shape: BrushShape) -> None:
    """Make a shape loaded from a user's file usable as a ``brush`` kind in this process
    (a built-in name cannot be replaced)."""
    if shape.name in builtin_shapes() or shape.name == "round":
        raise BrushShapeError(f"brush shape name {shape.name!r} is taken by a built-in brush")
    _REGISTERED[shape.name] = shape


def known_shapes() -> dict[str, BrushShape]:
    """Built-in and registered shapes by name."""
    return {**builtin_shapes(), **_REGISTERED}


def get_shape(name: str, where: str | None = None) -> BrushShape:
    shapes = known_shapes()
    if name not in shapes:
        raise BrushShapeError(f"unknown brush shape {name!r} (one of {', '.join(shapes)})",
                              where)
    return shapes[name]


def _bernstein(n: int, t: np.ndarray) -> np.ndarray:
    """``B_i^n(t)`` for i = 0..n: shape (len(t), n+1)."""
    i = np.arange(n + 1)
    comb = np.array([math.comb(n, k) for k in range(n + 1)], np.float64)
    tt = t[:, None]
    return comb * tt**i * (1.0 - tt) ** (n - i)


@numba.njit(cache=True)
def _round_lattice(joints: np.ndarray, frames: np.ndarray, radius: float, spread: float,
                   out: np.ndarray) -> None:  # pragma: no cover - compiled
    """The 2×2×(n+1) lattice of a one-spine tuft around ``joints`` (n+1, 3).

    Flattening (Chu et al.'s lateral nodes): a layer whose segment lies on the
    paper opens sideways (horizontally, across the segment) by ``spread`` and
    thins through the tuft, so a pressed round brush widens instead of only
    bending; ``flat`` goes smoothly from 0 (upright or clear of the paper) to 1.
    """
    for m in range(joints.shape[0]):
        ax, ay, az = -frames[m, 0, 2], -frames[m, 1, 2], -frames[m, 2, 2]
        sx, sy = -ay, ax  # ẑ × axis
        norm = math.sqrt(sx * sx + sy * sy)
        if norm < 1e-6:  # upright: any horizontal direction; the frame's X keeps twist
            sx, sy, sz = frames[m, 0, 0], frames[m, 1, 0], frames[m, 2, 0]
        else:
            sx, sy, sz = sx / norm, sy / norm, 0.0
        ux = ay * sz - az * sy  # axis × side
        uy = az * sx - ax * sz
        uz = ax * sy - ay * sx
        near = min(1.0, max(0.0, 1.0 - joints[m, 2] / radius))
        flat = (1.0 - abs(az)) * near
        across = radius * (1.0 + spread * flat)
        through = radius / (1.0 + spread * flat)
        for a in range(2):
            for b in range(2):
                fa, fb = (2 * a - 1) * across, (2 * b - 1) * through
                out[a, b, m, 0] = joints[m, 0] + fa * sx + fb * ux
                out[a, b, m, 1] = joints[m, 1] + fa * sy + fb * uy
                out[a, b, m, 2] = joints[m, 2] + fa * sz + fb * uz


def _mirror(tips: np.ndarray, around: np.ndarray, t0: np.ndarray) -> None:
    """Lay a multi-spine tuft's hairs (in place: tip lengths, across ``around`` in
    [0, 1], through ``t0`` in [-1, 1]) as a ``"mirrored"`` layout: a quarter of the
    draws laid evenly across one half of the ferrule (each jittered within its own
    share; the same draws, ranked), mirrored across the middle and through the
    thickness; each hair lies in one of the sheet's two faces (outer half of the
    thickness: a fan is a sheet two or three hairs thick). A fan's 28 hairs drawn
    independently left its deep-lying hairs on one side: the stroke pulled across its
    width sat 1.5 cells off the pen's line, and up and down strokes differed (which
    hairs lie low depends on the way the tuft bends); mirrored hairs in mid-thickness
    left a line down the stroke that none touched. The hairs left over lie on the
    middle."""
    nb = around.shape[0]
    q = nb // 4
    around[:q] = 0.5 * (np.argsort(np.argsort(around[:q])) + around[:q]) / max(q, 1)
    t0[:q] = np.sign(t0[:q]) * (0.5 + 0.5 * np.abs(t0[:q]))
    for k, (across, through) in enumerate(((True, False), (False, True), (True, True)), 1):
        part = slice(k * q, (k + 1) * q)
        tips[part] = tips[:q]
        around[part] = 1.0 - around[:q] if across else around[:q]
        t0[part] = -t0[:q] if through else t0[:q]
    around[4 * q:] = 0.5


class Tuft:
    """The bristles of a shape and their FFD weights (built once per shape)."""

    def __init__(self, shape: BrushShape) -> None:
        self.shape = shape
        rng = np.random.default_rng(shape.seed)
        nb = shape.bristles
        pu = np.array([p[0] for p in shape.profile])
        pw = np.array([p[1] for p in shape.profile])
        tips = 1.0 - shape.tip_spread * rng.random(nb)
        u = np.linspace(0.0, 1.0, SAMPLES)[None, :] * tips[:, None]  # (B, S)
        prof = np.interp(u, pu, pw)
        if shape.spines == 1:
            r = np.sqrt(rng.random(nb))
            a = 2.0 * math.pi * rng.random(nb)
            s0, t0 = r * np.cos(a), r * np.sin(a)  # unit disc
            s = 0.5 + 0.5 * s0[:, None] * prof
            t = 0.5 + 0.5 * t0[:, None] * prof
            rim = r
            around = a / (2.0 * math.pi)  # pressed, the tuft fans out: wedges → bands
        else:
            around = rng.random(nb)
            t0 = 2.0 * rng.random(nb) - 1.0
            if shape.layout == "mirrored":
                _mirror(tips, around, t0)
                u = np.linspace(0.0, 1.0, SAMPLES)[None, :] * tips[:, None]
                prof = np.interp(u, pu, pw)
            s = np.broadcast_to(around[:, None], u.shape)
            t = 0.5 + 0.5 * t0[:, None] * prof
            rim = np.abs(t0)
        # How each bristle keeps its ink once the tuft's liquid stops being one body
        # (below TuftModel.film_fill): the liquid draws neighbouring bristles into locks
        # that keep their share together, and retreats toward the core the ferrule
        # packs (finer pores hold it longer).  A draw of its own, so the geometry above
        # keeps its seed.  Retention 1 is the tuft's average share.
        draw = np.random.default_rng([shape.seed, 17])
        locks = max(3, nb // BRISTLES_PER_LOCK)
        lock = np.minimum((around * locks).astype(int), locks - 1)
        held = np.clip(draw.normal(0.0, 1.0, locks), -2.0, 2.0)[lock]
        own = np.clip(draw.normal(0.0, 1.0, nb), -2.0, 2.0)
        self.retention = np.exp(RETENTION_SPREAD * (held + 0.3 * own)) * (
            1.0 - RETENTION_RIM * (rim - rim.mean()))
        self.lattice_shape = (2 if shape.spines == 1 else shape.spines, 2, shape.segments + 1)
        na, nt, nu = self.lattice_shape
        bs = _bernstein(na - 1, s.ravel())
        bt = _bernstein(nt - 1, t.ravel())
        bu = _bernstein(nu - 1, u.ravel())
        w = bs[:, :, None, None] * bt[:, None, :, None] * bu[:, None, None, :]
        self.weights = np.ascontiguousarray(w.reshape(len(s.ravel()), na * nt * nu))
        self.n_bristles = nb
        self.coords = np.stack([s, t, u], axis=-1)

    def lattice(self, states: list[SpineState], roots: np.ndarray, handle: np.ndarray
                ) -> np.ndarray:
        """Control points (A, 2, n+1, 3) from the spines' angles at their roots."""
        shape = self.shape
        na, nt, nu = self.lattice_shape
        out = np.empty((na, nt, nu, 3))
        frames_all = []
        joints_all = []
        for st, root in zip(states, roots, strict=True):
            lengths = np.asarray(st.spec.lengths, np.float64)
            pos, frames, _ = chain(st.x, lengths, np.ascontiguousarray(root), handle)
            joints_all.append(np.vstack([root[None, :], pos]))
            frames_all.append(np.concatenate([frames[:1], frames], axis=0))
        if shape.spines == 1:
            _round_lattice(joints_all[0], frames_all[0], shape.radius, shape.spread, out)
        else:
            half = 0.5 * shape.thickness
            for a in range(na):
                for b in range(2):
                    out[a, b] = joints_all[a] + (2 * b - 1) * half * frames_all[a][:, :, 1]
        return out

    def deform(self, lattice: np.ndarray) -> np.ndarray:
        """Bristle points (B, SAMPLES, 3) for control points ``lattice``."""
        pts = self.weights @ lattice.reshape(-1, 3)
        out: np.ndarray = pts.reshape(self.n_bristles, SAMPLES, 3)
        return out
