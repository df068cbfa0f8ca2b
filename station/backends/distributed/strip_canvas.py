"""What a :class:`~station.backends.distributed.canvas.DistributedCanvas` knows of its
ranks' strips: the geometry, gathering a plane or the whole state on the root, float64
sums as one process sums them, and moving rows when the strip bounds change (collective
operations, the same on every rank)."""

from __future__ import annotations

import itertools
import time

import numpy as np
from mpi4py import MPI

from station.backends.distributed import decomp, exchange
from station.backends.distributed.exchange import Rect
from station.backends.distributed.strips import local_from_shell
from station.canvas.params import CanvasInputError, SimParams
from station.canvas.state import CanvasState

F32 = np.float32


class StripCanvas:
    """The strips of one canvas over the ranks of ``comm``; :class:`DistributedCanvas`
    sets every attribute below in its ``__init__`` and steps the strips."""

    comm: MPI.Comm
    rank: int
    size: int
    root: int
    base: str
    move_seconds: float  # time of the last strip move [s]
    _radius: int  # halo width [rows]
    _bounds: list[int]  # owned-row bounds of all ranks
    _strips: list[decomp.Strip]
    _shell: CanvasState  # replicated metadata and tiles (empty per-cell arrays)
    _local: CanvasState  # this rank's rows, halo included

    # ------------------------------------------------------------------ geometry
    @property
    def strip(self) -> decomp.Strip:
        """This rank's rows."""
        return self._strips[self.rank]

    @property
    def bounds(self) -> list[int]:
        """Owned-row bounds of all ranks (``size + 1`` rows)."""
        return list(self._bounds)

    @property
    def is_root(self) -> bool:
        return self.rank == self.root

    @property
    def renderer(self) -> str:
        return f"distributed ({self.size} ranks x {self.base})"

    @property
    def width(self) -> int:
        return self._shell.width

    @property
    def height(self) -> int:
        return self._shell.height

    @property
    def params(self) -> SimParams:
        return self._shell.params

    @property
    def n_slots(self) -> int:
        return self._local.n_slots

    @property
    def halo(self) -> int:
        """Halo width [rows]: the model's stencil radius."""
        return self._radius

    def _slots_used(self) -> int:
        return len(self._shell.slots)

    def _sync_local(self) -> None:
        """Metadata the passes read, from the shell to the local strip."""
        loc, sh = self._local, self._shell
        loc.slots = list(sh.slots)
        loc.sim_time = sh.sim_time
        loc.params = sh.params
        loc.profile = sh.profile
        loc.step_count = sh.step_count

    # ------------------------------------------------------------------ global sums
    def _gather_plane(self, plane: np.ndarray, tail: tuple[int, ...] = ()) -> np.ndarray | None:
        """The owned rows of ``plane`` (a local (rows, W, *tail) array) as one canvas
        array on the root (None elsewhere)."""
        s, sh = self.strip, self._shell
        per_row = sh.width * int(np.prod(tail, dtype=np.int64))
        mine = np.ascontiguousarray(plane[s.lo - s.pad_lo:s.hi - s.pad_lo], F32)
        if self.is_root:
            full = np.empty((sh.height, sh.width, *tail), F32)
            counts = [(b - a) * per_row for a, b in itertools.pairwise(self._bounds)]
            displs = [a * per_row for a in self._bounds[:-1]]
            self.comm.Gatherv(mine, [full, counts, displs, MPI.FLOAT], root=self.root)
            return full
        self.comm.Gatherv(mine, None, root=self.root)
        return None

    def _global_sum(self, plane: np.ndarray) -> float:
        """float64 sum over the canvas of a local plane, summed as one process sums it."""
        full = self._gather_plane(plane)
        total = float(full.sum(dtype=np.float64)) if full is not None else 0.0
        return float(self.comm.bcast(total, root=self.root))

    # ------------------------------------------------------------------ moving rows
    def set_bounds(self, bounds: list[int]) -> None:
        """Move to the given owned-row bounds (multiples of ``decomp.GRANULE``; tests,
        tools)."""
        g = decomp.GRANULE
        if (len(bounds) != self.size + 1 or bounds[0] != 0 or bounds[-1] != self.height
                or any(b % g and b != self.height for b in bounds)
                or any(a >= b for a, b in itertools.pairwise(bounds))):
            raise CanvasInputError(f"bounds {bounds} are not {self.size} strips cut at "
                                   f"multiples of {g} rows", "bounds")
        self._redistribute(list(bounds))

    def _redistribute(self, bounds: list[int]) -> None:
        """Every rank gets the rows of its new strip (owned and halo) from their owners."""
        t0 = time.perf_counter()
        old = self._strips
        new = decomp.strips(bounds, self.height, self._radius)
        plan: dict[tuple[int, int], list[Rect]] = {}
        for r, sn in enumerate(new):
            for o, so in enumerate(old):
                a, b = max(sn.pad_lo, so.lo), min(sn.pad_hi, so.hi)
                if a < b:
                    plan.setdefault((o, r), []).append((a, b, 0, self.width))
        loc = self._local
        s_new, s_old = new[self.rank], old[self.rank]
        self._sync_local()
        fresh = local_from_shell(self._shell, s_new.rows, zeroed=False)
        fresh.slots = list(loc.slots)
        # rows this rank keeps: a plain copy, not through a message buffer
        a, b = max(s_new.pad_lo, s_old.lo), min(s_new.pad_hi, s_old.hi)
        if a < b:
            for n in exchange.ALL_FIELDS:
                src, dst = getattr(loc, n), getattr(fresh, n)
                if n in exchange.STACKS or n == "fibre":
                    dst[:, a - s_new.pad_lo:b - s_new.pad_lo] = src[:, a - s_old.pad_lo:
                                                                     b - s_old.pad_lo]
                else:
                    dst[a - s_new.pad_lo:b - s_new.pad_lo] = src[a - s_old.pad_lo:
                                                                 b - s_old.pad_lo]
        plan.pop((self.rank, self.rank), None)
        exchange.move(self.comm, loc, s_old.pad_lo, fresh, s_new.pad_lo, plan,
                      exchange.ALL_FIELDS, max(self._slots_used(), 1), exchange.TAG_MOVE)
        self._local = fresh
        self._bounds = list(bounds)
        self._strips = new
        self.move_seconds = time.perf_counter() - t0

    def gather_state(self) -> CanvasState | None:
        """The whole state on the root, ``None`` on the other ranks (collective)."""
        sh, loc = self._shell, self._local
        arrays: dict[str, np.ndarray | None] = {}
        for n in exchange.PLANES:
            arrays[n] = self._gather_plane(getattr(loc, n))
        for n in exchange.STACKS:
            planes = [self._gather_plane(getattr(loc, n)[k]) for k in range(len(sh.slots))]
            if self.is_root:
                full = np.zeros((loc.n_slots, sh.height, sh.width), F32)
                for k, pl in enumerate(planes):
                    full[k] = pl
                arrays[n] = full
        arrays["r_composed"] = self._gather_plane(loc.r_composed, (loc.r_composed.shape[-1],))
        fibres = [self._gather_plane(loc.fibre[k]) for k in range(2)]
        if self.is_root:
            arrays["fibre"] = np.stack([f for f in fibres if f is not None])
        if not self.is_root:
            return None
        st = sh.copy()
        for n, a in arrays.items():
            setattr(st, n, a)
        return st
