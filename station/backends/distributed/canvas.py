"""``DistributedCanvas``: one canvas simulated by all ranks of an MPI communicator.

Every rank runs the same program (SPMD): the same session player feeds the same
brush sources, commands and steps to its ``DistributedCanvas``; each rank holds a
row strip of the canvas (``decomp.Strip``: owned rows plus a halo of
``reference.stencil_radius`` rows) in a local :class:`CanvasState` and steps it with
the ``numpy`` or ``cpu`` backend's own ``step_region``. The result is bitwise the
result of one process:

* the dirty tiles (``tile_ttl``) and every other piece of global metadata live in a
  *shell* (a ``CanvasState`` with empty per-cell arrays) replicated on all ranks and
  changed only by the same deterministic code on all of them;
* each step simulates, per dirty-tile box ``B`` of the one-process step, the part of
  ``B`` a rank holds; the cells within one stencil radius of a held edge inside ``B``
  come out wrong and are exactly the halo cells, refreshed from their owners right
  after the step (only the rows of the boxes: nothing else changed);
* a tile's "still holds water" test is a max-reduction of the owners' answers;
* float64 totals (evaporation folding, layer deposits) are summed by the root over
  the gathered plane, in the order one process sums it;
* brush sources go to every rank (each applies the cells it holds, halo included),
  and the water/pigment actually added is reduced so the books match exactly.

Work follows the painting: every ``rebalance_every`` steps the strip bounds are
recomputed from the cells the dirty-tile boxes simulate per tile row
(``decomp.balanced_split``) and rows move to their new owners.

Split by job: the shell, the local strip and the border bands are in ``strips``; the
strips' geometry, gathering and moving rows in ``strip_canvas`` (the base class); this
module holds the sources, the step and its halo schedule, commands, balance and display.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from mpi4py import MPI

from station.backends.distributed import boxes, decomp, exchange
from station.backends.distributed.exchange import Rect
from station.backends.distributed.strip_canvas import StripCanvas
from station.backends.distributed.strips import (
    Band,
    empty_shell,
    local_from_shell,
    zero_fibre,
    zero_plane,
)
from station.canvas import operations, reference, tiles
from station.canvas.palette import Palette
from station.canvas.paper import make_fibres, make_paper
from station.canvas.params import CanvasInputError, SimParams
from station.canvas.profiles import get_profile
from station.canvas.state import DEFAULT_SLOTS, CanvasState, check_size
from station.canvas.stats import CanvasStats, canvas_stats
from station.render.km import render_bands, render_state

if TYPE_CHECKING:
    from station.backends.cpu import step as cpu_step

F32 = np.float32
BASES = ("numpy", "cpu")
SCHEDULES = ("auto", "overlap", "blocking")
REBALANCE_THRESHOLD = 1.04
"""Rebalance only when the busiest rank has this much more work than the mean (and the
move pays for itself: :meth:`DistributedCanvas.rebalance`)."""
STEP_TIME_WEIGHT = 0.1
"""Weight of the newest step in the running mean of the step time (``step_seconds``)."""


class DistributedCanvas(StripCanvas):
    """The canvas backend protocol over MPI ranks (see the module docstring).

    Args:
        width, height, profile, seed, tiling, n_slots, params, paper, palette: as
            :class:`~station.backends.numpy_canvas.NumpyCanvas`.
        base: the backend whose step runs on each strip: ``numpy`` or ``cpu``.
        comm: the communicator (default ``MPI.COMM_WORLD``).
        rebalance_every: steps between load-balance checks (0: never).
        schedule: the halo schedule (:data:`SCHEDULES`): ``overlap`` steps each box's
            interior while its halo travels and the border bands after (2 radius rows of
            extra work per border); ``blocking`` waits for the halo first; ``auto`` (the
            default, or ``$STATION_HALO_SCHEDULE``) overlaps a box only where a neighbour
            across its borders is on another machine (MPI's shared-memory split): over
            shared memory the halo arrives faster than the bands' extra work.
        root: the rank that gathers pictures, states and statistics.
    """

    def __init__(self, width: int, height: int, profile: str = "watercolor", seed: int = 0,
                 *, base: str = "numpy", comm: MPI.Comm | None = None, tiling: bool = True,
                 tiles: bool | None = None, n_slots: int = DEFAULT_SLOTS,
                 params: SimParams | None = None, paper: str | None = None,
                 palette: Palette | None = None, rebalance_every: int = 64,
                 root: int = 0, schedule: str | None = None) -> None:
        if base not in BASES:
            raise CanvasInputError(f"distributed base backend {base!r} (known: "
                                   f"{', '.join(BASES)})", "--backend")
        check_size(width, height)
        if tiles is not None:
            tiling = tiles
        self.comm = comm if comm is not None else MPI.COMM_WORLD
        self.rank = self.comm.Get_rank()
        self.size = self.comm.Get_size()
        # which machine each rank runs on: found at the first step, because making a
        # canvas must not be collective (station sim's rank 0 makes it before the others)
        self._node_of: list[int] | None = None
        self.root = root
        self.base = base
        self.rebalance_every = int(rebalance_every)
        schedule = schedule or os.environ.get("STATION_HALO_SCHEDULE", "") or "auto"
        if schedule not in SCHEDULES:
            raise CanvasInputError(f"halo schedule {schedule!r} (known: "
                                   f"{', '.join(SCHEDULES)})", "STATION_HALO_SCHEDULE")
        self.schedule = schedule
        prof = get_profile(profile)
        prm = params if params is not None else prof.params
        preset = paper if paper is not None else prof.paper
        self._radius = reference.stencil_radius(prm)
        ts = int(prm.tile_size)
        if height < ts * self.size:
            raise CanvasInputError(f"canvas of {height} rows cannot give {self.size} ranks "
                                   f"a tile row ({ts} rows) each", "--size")
        self._bounds = decomp.even_split(height, ts, self.size)
        self._strips = decomp.strips(self._bounds, height, self._radius)
        s = self.strip
        h = make_paper(preset, height, width, seed)[s.pad_lo:s.pad_hi]
        self._local = CanvasState.blank(width, s.rows, prm, h, profile=prof.name,
                                        paper_preset=preset, seed=seed, palette=palette,
                                        n_slots=n_slots, tiling=tiling)
        # the strip's rows of the whole sheet's fibres (a strip-sized sheet has others)
        self._local.fibre = np.ascontiguousarray(
            make_fibres(preset, height, width, seed)[:, s.pad_lo:s.pad_hi])
        full_ttl = np.zeros((-(-height // ts), -(-width // ts)), np.int32)
        self._shell = empty_shell(dataclasses.replace(self._local, tile_ttl=full_ttl))
        self._shell.width, self._shell.height = width, height
        self._shell.fibre = zero_fibre(height, width)
        self._shell.wet_area = zero_plane(height, width)
        self._renderer_kind = prof.renderer
        self._scratch: cpu_step.Scratch | None = None
        self._band_scratch: cpu_step.Scratch | None = None
        self._boxes_of: tuple[tuple[int, int, int], np.ndarray,
                              list[tuple[slice, slice]]] | None = None
        self._image: np.ndarray | None = None
        self._dirty = np.ones(full_ttl.shape, bool)
        self._shown = False  # no picture sent to the root yet (same on every rank)
        self.halo_bytes_last = 0
        self.render_cells_last = 0  # cells this rank sent for the last picture
        self.comm_seconds = 0.0  # halo exchange + tile reduction, waiting included [s]
        self.halo_wait_seconds = 0.0  # waiting for the halo after the interior work [s]
        self.halo_hidden_seconds = 0.0  # interior work done while the halo travels [s]
        self.step_seconds = 0.0  # running mean of this rank's step time [s]
        self.move_seconds = 0.0  # time of the last strip move [s]
        self.band_steps = 0  # border bands stepped after an overlapped exchange
        self.late_steps = 0  # boxes stepped only after waiting for their halo
        self.cells_last = 0
        self.rebalances = 0

    # ------------------------------------------------------------------ sources
    def add_sources(self, dw: np.ndarray | None = None,
                    dp: Mapping[str, np.ndarray] | None = None,
                    dvx: np.ndarray | None = None, dvy: np.ndarray | None = None,
                    *, y0: int = 0, x0: int = 0) -> None:
        """Brush/tool sources on every rank's cells; books and tiles as one process."""
        sh, loc, s = self._shell, self._local, self.strip
        dp = dict(dp or {})
        # the checks of operations.add_sources on the whole canvas, so every rank
        # refuses the same input before anything changes
        placed_p = {}
        for name, arr in dp.items():
            sh.palette.get(name)
            pl = operations._placed(sh, arr, y0, x0, f"dp[{name!r}]")
            if pl is not None:
                if (pl[1] < 0).any():
                    raise CanvasInputError("pigment sources must be >= 0", "add_sources")
                if pl[1].any():
                    placed_p[name] = pl
        placed_w = operations._placed(sh, dw, y0, x0, "dw") if dw is not None else None
        if placed_w is not None and (placed_w[1] < 0).any():
            raise CanvasInputError("water sources must be >= 0", "add_sources")
        placed_v = [(operations._placed(sh, a, y0, x0, n) if a is not None else None)
                    for a, n in ((dvx, "dvx"), (dvy, "dvy"))]
        new = {sh.palette.get(n).name for n in placed_p} - set(sh.slots)
        if len(new) > sh.n_slots - len(sh.slots):
            raise CanvasInputError(
                f"the active layer holds {len(sh.slots)} of {sh.n_slots} pigments; "
                "start a new layer for more", "pigment")
        self._sync_local()
        for name in placed_p:  # slots in the order one process assigns them
            loc.slot_of(name)
        sh.slots = list(loc.slots)

        # what this rank owns of the footprint, before and after
        own_lo, own_hi = s.lo, s.hi
        def owned(sl: tuple[slice, slice]) -> tuple[slice, slice, slice] | None:
            a, b = max(sl[0].start, own_lo), min(sl[0].stop, own_hi)
            if a >= b:
                return None
            return (slice(a - s.pad_lo, b - s.pad_lo), slice(a - sl[0].start, b - sl[0].start),
                    sl[1])
        books: list[tuple[str | None, tuple[slice, slice], np.ndarray]] = []
        if placed_w is not None:
            books.append((None, placed_w[0], loc.w))
        for name, (sl, _a) in placed_p.items():
            books.append((name, sl, loc.p[sh.slots.index(sh.palette.get(name).name)]))
        before = []
        for _n, sl, arr in books:
            o = owned(sl)
            before.append(arr[o[0], o[2]].copy() if o is not None else None)
        operations.add_sources(loc, dw, dp, dvx, dvy, y0=y0 - s.pad_lo, x0=x0)
        # the amounts actually added, assembled on every rank in one reduction
        sizes = [(sl[0].stop - sl[0].start) * (sl[1].stop - sl[1].start) for _n, sl, _a in books]
        delta = np.zeros(sum(sizes), F32)
        pos = 0
        for (_n, sl, arr), b0, size in zip(books, before, sizes, strict=True):
            o = owned(sl)
            if o is not None and b0 is not None:
                view = delta[pos:pos + size].reshape(sl[0].stop - sl[0].start, -1)
                view[o[1], :] = arr[o[0], o[2]] - b0
            pos += size
        if delta.size:
            exchange.wait_all([self.comm.Iallreduce(MPI.IN_PLACE, delta, op=MPI.SUM)])
        pos = 0
        for (pig, _sl, _a), size in zip(books, sizes, strict=True):
            added = float(delta[pos:pos + size].sum(dtype=np.float64))
            pos += size
            if pig is None:
                sh.water_added += added
            else:
                pname = sh.palette.get(pig).name
                sh.pigment_added[pname] = sh.pigment_added.get(pname, 0.0) + added
        touched = [pl for pl in (placed_w, *placed_p.values(), *placed_v) if pl is not None]
        ts = int(sh.params.tile_size)
        for sl, a in touched:
            tiles.mark_nonzero(sh, sl[0], sl[1], a)
            self._dirty[sl[0].start // ts:-(-sl[0].stop // ts),
                        sl[1].start // ts:-(-sl[1].stop // ts)] = True

    # ------------------------------------------------------------------ step
    def _step_region(self, sl: tuple[slice, slice], dt: float) -> None:
        loc = self._local
        if self.base == "numpy":
            reference.step_region(loc, sl, dt)
            return
        from station.backends.cpu import step as cpu_step  # numba only for the cpu base

        slots = max(len(loc.slots), 1)
        sc = self._scratch
        # a box window only needs a scratch at least its size: keep it when bounds move
        # (a new one is page-faulted in again, ~1 GB for a 3500-row strip at 4096 wide)
        if sc is None or sc.height < loc.height or sc.width < loc.width or sc.slots < slots:
            sc = self._scratch = cpu_step.Scratch(loc.height, loc.width, max(slots, 2))
        cpu_step.step_region(loc, sl, dt, sc)

    def _regions(self) -> list[tuple[slice, slice]]:
        sh = self._shell
        if not sh.tiling:
            return [(slice(0, sh.height), slice(0, sh.width))]
        active = sh.tile_ttl > 0
        key = (sh.height, sh.width, int(sh.params.tile_size))
        # the active tiles change far less often than every step: find boxes only then
        if (self._boxes_of is None or self._boxes_of[0] != key
                or not np.array_equal(active, self._boxes_of[1])):
            self._boxes_of = (key, active, boxes.active_regions(sh))
        return list(self._boxes_of[2])

    def step(self, dt: float | None = None) -> None:
        """One step of the whole canvas; the halo exchange overlaps the interior work.

        Per dirty-tile box: the halo rows are posted (non-blocking), the rows of the
        box this rank owns are stepped in place (all but the ``radius`` rows next to a
        border come out right: they do not reach the halo), and, once the halo is in,
        each border's last ``radius`` owned rows are stepped on a copy of the
        ``3 x radius`` rows around the border (``Band``) and written back. A box whose
        owned part is shorter than ``2 x radius`` rows, every box under the ``blocking``
        schedule, and under ``auto`` every box whose neighbours run on this machine, wait
        for the halo and are stepped with it in place.
        """
        sh, s = self._shell, self.strip
        dt = sh.params.dt if dt is None else float(dt)
        if not dt > 0 or dt * sh.params.v_max > 1.0 + 1e-9:
            raise CanvasInputError("dt must be > 0 and move at most one cell per step", "step")
        t_begin = time.perf_counter()
        if self._node_of is None:
            node = self.comm.Split_type(MPI.COMM_TYPE_SHARED)
            self._node_of = self.comm.allgather(node.allreduce(self.rank, op=MPI.MIN))
            node.Free()
        self._sync_local()
        regions = self._regions()
        t0 = time.perf_counter()
        pending = exchange.start(self.comm, self._local, s.pad_lo, self._local, s.pad_lo,
                                 self._halo_plan(regions), exchange.DYNAMIC_FIELDS,
                                 max(self._slots_used(), 1), exchange.TAG_HALO)
        t1 = time.perf_counter()
        rad, off = self._radius, s.pad_lo
        late: list[tuple[slice, slice]] = []
        bands: list[Band] = []
        cells = 0
        # only the steps taken while the halo travels count as hidden work: the loop's
        # own bookkeeping is not overlapped work (a blocking schedule hides none)
        hidden = 0.0
        for ys, xs in regions:
            a, b = max(ys.start, s.pad_lo), min(ys.stop, s.pad_hi)
            oa, ob = max(ys.start, s.lo), min(ys.stop, s.hi)
            if ob <= oa:
                continue  # nothing of this box is ours
            top, bottom = ys.start < s.lo, ys.stop > s.hi
            cols = xs.stop - xs.start
            if not (top or bottom):
                w0 = time.perf_counter()
                self._step_region((slice(oa - off, ob - off), xs), dt)
                hidden += time.perf_counter() - w0
                cells += (ob - oa) * cols
            elif not self._overlaps(top, bottom) or ob - oa < 2 * rad:
                late.append((slice(a - off, b - off), xs))
                cells += (b - a) * cols
            else:  # snapshot the border rows before the interior step overwrites them
                loc = self._local
                if top:
                    bands.append(Band(loc, off, a, oa + 2 * rad, xs, (oa, oa + rad), (a, oa)))
                    cells += (oa + 2 * rad - a) * cols
                if bottom:
                    bands.append(Band(loc, off, ob - 2 * rad, b, xs, (ob - rad, ob), (ob, b)))
                    cells += (b - ob + 2 * rad) * cols
                w0 = time.perf_counter()
                self._step_region((slice(oa - off, ob - off), xs), dt)
                hidden += time.perf_counter() - w0
                cells += (ob - oa) * cols
        t2 = time.perf_counter()
        self.halo_bytes_last = exchange.finish(pending)
        t3 = time.perf_counter()
        for bd in bands:
            bd.step(self._local, off, self._band_step, dt)
        for sl in late:
            self._step_region(sl, dt)
        self.band_steps += len(bands)
        self.late_steps += len(late)
        self.cells_last = cells
        t4 = time.perf_counter()
        if sh.tiling:
            self._update_tiles(regions)
        t5 = time.perf_counter()
        self.comm_seconds += (t1 - t0) + (t3 - t2) + (t5 - t4)
        took = t5 - t_begin
        self.step_seconds = (took if self.step_seconds == 0.0 else
                             self.step_seconds + STEP_TIME_WEIGHT * (took - self.step_seconds))
        self.halo_wait_seconds += t3 - t2
        self.halo_hidden_seconds += hidden
        ts = int(sh.params.tile_size)
        for ys, xs in regions:
            self._dirty[ys.start // ts:-(-ys.stop // ts), xs.start // ts:-(-xs.stop // ts)] = True
        sh.sim_time += dt
        sh.step_count += 1
        if sh.step_count % operations.FOLD_EVERY == 0:
            sh.evaporated_folded += self._global_sum(self._local.evaporated)
            self._local.evaporated[...] = 0
        if self.rebalance_every > 0 and sh.step_count % self.rebalance_every == 0:
            self.rebalance()

    def _overlaps(self, top: bool, bottom: bool) -> bool:
        """Whether a box crossing the top/bottom border is stepped overlapped."""
        if self.schedule != "auto":
            return self.schedule == "overlap"
        nodes = self._node_of or []
        me = nodes[self.rank]
        return ((top and nodes[self.rank - 1] != me)
                or (bottom and nodes[self.rank + 1] != me))

    def _band_step(self, band: CanvasState, dt: float) -> None:
        """Step all of a border band (its own scratch: bands are at most 3 radius rows)."""
        sl = (slice(0, band.height), slice(0, band.width))
        if self.base == "numpy":
            reference.step_region(band, sl, dt)
            return
        from station.backends.cpu import step as cpu_step  # numba only for the cpu base

        slots = max(len(band.slots), 2)
        sc = self._band_scratch
        if sc is None or sc.height < band.height or sc.width < band.width or sc.slots < slots:
            sc = self._band_scratch = cpu_step.Scratch(
                max(3 * self._radius, band.height), self.width, slots)
        cpu_step.step_region(band, sl, dt, sc)

    def _halo_plan(self, regions: list[tuple[slice, slice]]) -> dict[tuple[int, int], list[Rect]]:
        """Who sends whom which halo cells inside the boxes (same on every rank)."""
        plan: dict[tuple[int, int], list[Rect]] = {}
        for r, sr in enumerate(self._strips):
            for h0, h1 in ((sr.pad_lo, sr.lo), (sr.hi, sr.pad_hi)):
                for ys, xs in regions:
                    a0, a1 = max(h0, ys.start), min(h1, ys.stop)
                    for o, so in enumerate(self._strips):
                        b0, b1 = max(a0, so.lo), min(a1, so.hi)
                        if b0 < b1 and o != r:
                            plan.setdefault((o, r), []).append((b0, b1, xs.start, xs.stop))
        return plan

    def _update_tiles(self, regions: list[tuple[slice, slice]]) -> None:
        """``tiles.update_tiles`` with the "still holds water" test reduced over owners."""
        sh, loc, s = self._shell, self._local, self.strip
        ttl = sh.tile_ttl
        np.subtract(ttl, 1, out=ttl, where=ttl > 0)
        ts = int(sh.params.tile_size)
        alive = np.zeros(ttl.shape, np.uint8)
        inside = np.zeros(ttl.shape, bool)
        for ys, xs in regions:
            ty0, ty1 = ys.start // ts, -(-ys.stop // ts)
            tx0, tx1 = xs.start // ts, -(-xs.stop // ts)
            inside[ty0:ty1, tx0:tx1] = True
            r0, r1 = max(ty0 * ts, s.lo), min(ty1 * ts, sh.height, s.hi)
            if r0 >= r1:
                continue
            c0, c1 = tx0 * ts, min(tx1 * ts, sh.width)
            a, b = r0 - s.pad_lo, r1 - s.pad_lo
            live = (loc.w[a:b, c0:c1] > 0) | (loc.wc[a:b, c0:c1] > 0)
            cols = np.zeros((r1 - r0, (tx1 - tx0) * ts), bool)
            cols[:, :c1 - c0] = live
            per_col = cols.reshape(r1 - r0, tx1 - tx0, ts).any(axis=2)
            trow = np.arange(r0, r1) // ts
            starts = np.flatnonzero(np.r_[True, trow[1:] != trow[:-1]])
            red = np.logical_or.reduceat(per_col, starts, axis=0)
            alive[trow[starts], tx0:tx1] |= red.astype(np.uint8)
        exchange.wait_all([self.comm.Iallreduce(MPI.IN_PLACE, alive, op=MPI.MAX)])
        renew = (alive > 0) & inside & (ttl <= 0)
        ttl[renew] = sh.params.tile_ttl_steps()

    # ------------------------------------------------------------------ commands
    def dry(self) -> None:
        self._sync_local()
        operations.dry(self._local)
        self._shell.tile_ttl[...] = 0
        self._dirty[...] = True

    def new_layer(self) -> None:
        """``NumpyCanvas.new_layer`` with the layer's float64 totals summed globally."""
        sh, loc = self._shell, self._local
        self.dry()
        loc.r_composed[...] = render_bands(loc, self._renderer_kind)
        layer = {name: self._global_sum(loc.q[k]) for k, name in enumerate(sh.slots)}
        sh.layers.append(layer)
        for k, name in enumerate(sh.slots):
            sh.pigment_dried[name] = sh.pigment_dried.get(name, 0.0) + layer[name]
            sh.pigment_removed_past[name] = (sh.pigment_removed_past.get(name, 0.0)
                                             + self._global_sum(loc.removed_p[k]))
        loc.p[...] = 0
        loc.q[...] = 0
        loc.removed_p[...] = 0
        sh.slots = []
        loc.slots = []

    def clear(self) -> None:
        operations.clear(self._local)
        operations.clear(self._shell)
        self._dirty[...] = True

    def set_profile(self, name: str) -> None:
        operations.set_profile(self._shell, name)
        operations.set_profile(self._local, name)
        self._radius_check()
        self._renderer_kind = get_profile(name).renderer
        self._dirty[...] = True

    def _radius_check(self) -> None:
        r = reference.stencil_radius(self._shell.params)
        if r != self._radius:  # a profile with more Jacobi iterations: wider halos
            self._radius = r
            self._redistribute(self._bounds)

    # ------------------------------------------------------------------ balance
    def rebalance(self, force: bool = False) -> bool:
        """Move strip bounds to share the dirty-tile work; True when rows moved
        (collective).

        Rows move when the busiest rank has :data:`REBALANCE_THRESHOLD` times the mean
        work and the time the balanced split would save until the next check (the
        slowest rank's mean step time x ``rebalance_every`` x ``1 - 1/imbalance``)
        exceeds the last move's time: a move copies whole strips (~0.5 s for a
        3500-row strip at 4096 wide), which a 4 % imbalance does not repay in 64 steps.
        ``force``: move to the balanced split even when the imbalance is small.
        """
        sh = self._shell
        g = decomp.GRANULE
        work = decomp.row_work(self._regions(), sh.height, sh.width, g)
        new = decomp.balanced_split(work, sh.height, g, self.size)
        if new == self._bounds:
            return False
        imb = decomp.imbalance(work, self._bounds, g)
        # every rank must decide alike: the slowest rank's step and move times
        times = np.array([self.step_seconds, self.move_seconds])
        exchange.wait_all([self.comm.Iallreduce(MPI.IN_PLACE, times, op=MPI.MAX)])
        # moving pays when the steps until the next check save more than a move costs
        saving = self.rebalance_every * times[0] * (1.0 - 1.0 / imb)
        if not force and (imb < REBALANCE_THRESHOLD or saving < times[1]):
            return False
        self._redistribute(new)
        self.rebalances += 1
        return True

    # ------------------------------------------------------------------ state
    def state(self) -> CanvasState:
        """The whole state, gathered on the root (collective). Other ranks get the
        replicated metadata with empty per-cell arrays."""
        full = self.gather_state()
        return full if full is not None else self._shell.copy()

    def load_state(self, state: CanvasState | None) -> None:
        """Continue from ``state``, given on the root (other ranks may pass None):
        metadata is broadcast, each rank receives its rows (collective)."""
        shell = empty_shell(state) if self.is_root and state is not None else None
        if shell is not None:
            shell.fibre = np.zeros((2, 0, 0), F32)  # not pickled whole: set again below
            shell.wet_area = np.zeros((0, 0), F32)
        shell = self.comm.bcast(shell, root=self.root)
        if shell is None:
            raise CanvasInputError("load_state needs a state on the root rank", "load_state")
        shell.fibre = zero_fibre(shell.height, shell.width)
        shell.wet_area = zero_plane(shell.height, shell.width)
        ts = int(shell.params.tile_size)
        if shell.height < ts * self.size:
            raise CanvasInputError(f"canvas of {shell.height} rows cannot give {self.size} "
                                   f"ranks a tile row each", "load_state")
        self._shell = shell
        self._radius = reference.stencil_radius(shell.params)
        self._bounds = decomp.even_split(shell.height, ts, self.size)
        self._strips = decomp.strips(self._bounds, shell.height, self._radius)
        s = self.strip
        loc = local_from_shell(shell, s.rows)
        plan = {(self.root, r): [(st.pad_lo, st.pad_hi, 0, shell.width)]
                for r, st in enumerate(self._strips)}
        exchange.move(self.comm, state if self.is_root else None, 0, loc, s.pad_lo, plan,
                      exchange.ALL_FIELDS, max(len(shell.slots), 1), exchange.TAG_MOVE)
        self._local = loc
        self._renderer_kind = get_profile(shell.profile).renderer
        self._scratch = None
        self._dirty[...] = True
        if self._dirty.shape != shell.tile_ttl.shape:
            self._dirty = np.ones(shell.tile_ttl.shape, bool)
        self._image = None
        self._shown = False

    def stats(self) -> CanvasStats:
        """``--stats`` of the whole canvas (computed on the root, sent to all)."""
        full = self.gather_state()
        st = canvas_stats(full, self.renderer) if full is not None else None
        out: CanvasStats = self.comm.bcast(st, root=self.root)
        return out

    # ------------------------------------------------------------------ display
    def render(self) -> np.ndarray:
        """Linear reflectance (H, W, 3) on the root; an empty (0, W, 3) array elsewhere.

        Each rank renders the tile rows it owns that changed since the last render and
        sends only those bands (bounded by their changed tiles) to the root, which
        keeps the last picture.
        """
        sh, loc, s = self._shell, self._local, self.strip
        ts = int(sh.params.tile_size)
        if not self._shown:
            self._dirty[...] = True
        bands = []
        for ty in range(s.lo // ts, -(-s.hi // ts)):
            cols = np.flatnonzero(self._dirty[ty])
            if cols.size == 0:
                continue
            r0, r1 = max(ty * ts, s.lo), min((ty + 1) * ts, s.hi)
            c0, c1 = int(cols[0]) * ts, min((int(cols[-1]) + 1) * ts, sh.width)
            a, b = r0 - s.pad_lo, r1 - s.pad_lo
            view = dataclasses.replace(loc, p=loc.p[:, a:b, c0:c1], q=loc.q[:, a:b, c0:c1],
                                       r_composed=loc.r_composed[a:b, c0:c1])
            bands.append((r0, r1, c0, c1, render_state(view, self._renderer_kind)))
        self._dirty[...] = False
        self._shown = True
        self.render_cells_last = sum((b[1] - b[0]) * (b[3] - b[2]) for b in bands)
        got = self.comm.gather(bands, root=self.root)
        if not self.is_root:
            return np.zeros((0, sh.width, 3), F32)
        if self._image is None:
            self._image = np.empty((sh.height, sh.width, 3), F32)
        for part in got or []:
            for r0, r1, c0, c1, rgb in part:
                self._image[r0:r1, c0:c1] = rgb
        return self._image.copy()

    # ------------------------------------------------------------------ extras
    def sync(self) -> None:
        """Wait for all ranks (benchmarks)."""
        self.comm.Barrier()

    def close(self) -> None:
        """Nothing held beyond memory."""

    def cells_last_step(self) -> int:
        """Cells this rank simulated in the last step (halo overlap included)."""
        return self.cells_last

    def save(self, path: str) -> None:
        """Gather and write the state on the root (collective): one file, loadable by one
        process."""
        full = self.gather_state()
        if full is not None:
            full.save(path)

    def load(self, path: str) -> None:
        """Read a state file on the root and scatter it (collective)."""
        self.load_state(CanvasState.load(path) if self.is_root else None)
