"""The canvas as a texture for the window, re-rendered as little as possible.

Both displays give a texture of *linear* reflectance (the window's shader
applies the sRGB transfer), row 0 = the canvas's top row.

* :class:`CpuDisplay` (numpy and cpu backends): Kubelka–Munk render of the
  dirty tiles only (runs of at most :data:`RUN_TILES` tiles in a tile row; the
  numba twin of the reference KM in :mod:`station.render.km_fast`, gouache by
  the reference), uploaded with ``texture.write(viewport=…)`` — only the box of
  texels that changed by more than a tenth of a level on screen, against a mirror of
  what the texture holds, so a wet tile re-rendered at every step redraws only where
  its paint moved —, for at most :data:`TILE_BUDGET_S` a frame (the rest in the
  next frames).  Brush stamps
  made since the last simulation step are shown at once as a preview (the same
  KM render of the state plus those stamps' pigment, capped as ``add_sources``
  caps it), rendered after the window's late latch, so a pen stroke appears in
  the frame that takes it and not only after the next step; the preview stays
  until a step takes its stamps, and each frame renders only the new stamps'
  cells.
* :class:`GpuDisplay` (gl backend): the canvas's render pass writes its own
  RGBA32F texture in the window's GL context, and three compute passes make of it
  the same colour-and-contour-level texture as the CPU displays'
  (:mod:`station.kiosk.gl_fields`); the window samples it with no read-back.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Protocol

import numba
import numpy as np

from station.brush.stamp import Sources, StampPreview
from station.canvas.profiles import get_profile
from station.kiosk import subcell
from station.kiosk.gl_fields import GlFields
from station.render.km import region_amount, render_region
from station.render.km_fast import km_layer_fast

if TYPE_CHECKING:
    import moderngl

F32 = np.float32

#: Cells of dirty tiles re-rendered in one frame at most (the pending stamps' preview
#: always is): a step that wets many tiles, or a whole-canvas command, is shown over a
#: few frames instead of stalling one (800×600 is 480 000 cells, about 5 ms here).
MAX_CELLS_PER_FRAME = 120_000

#: Seconds of dirty-tile rendering in one frame at most (checked after each run of
#: tiles).  Every millisecond spent here is a millisecond a pen sample arriving now
#: waits before the window takes it (:meth:`CpuDisplay.update_tiles` comes before the
#: late latch): so a step's changes are shown over a few short frames — the wet paint
#: moves on screen a few milliseconds later — and the pen is never held up by them.
TILE_BUDGET_S = 0.0015

#: A fresh preview (a step took the previewed stamps, or began while they were shown)
#: larger than this (cells) is not rendered at once: the tiles its stamps cover are marked
#: dirty and drawn, with those stamps, within the tiles' budget over the next frames (the
#: stamps are on screen meanwhile from the frames that previewed them).  While a wholly
#: wet 1920×1080 canvas steps slower than real time, stamps stay pending for a second
#: or more (each is due at its painting time), and the fresh preview's box spanned most
#: of the stroke: 200 000-530 000 cells, 60-560 ms in one frame — the frame-time p99
#: of the wet sky.  A live stroke at 30 steps/s previews a few thousand cells.
PREVIEW_CELLS = 16_384

#: Regions smaller than this (cells) are rendered by one thread.
SERIAL_CELLS = 2048

#: Tiles in one run at most (a run is rendered and uploaded in one call): the budget
#: is checked this often.
RUN_TILES = 4


#: A texel is uploaded when its linear colour changed by more than this (0.1 of an 8-bit
#: level on screen at the sRGB curve's steepest, 12.92, through the bicubic's weights)
#: or its contour level by more than this (a hundredth of a level where a pixel spans
#: a twentieth of the level's ramp, the brush view's magnification).
SHOWN_COLOUR_TOL = 2e-5
SHOWN_LEVEL_TOL = 1e-5


@numba.njit(cache=True, nogil=True)
def _changed_box(new: np.ndarray, shown: np.ndarray, tol_colour: np.float32,
                 tol_level: np.float32, box: np.ndarray) -> bool:  # pragma: no cover
    """The bounding box (y0, y1, x0, x1 into ``box``) of the texels of ``new`` that
    differ from ``shown`` by more than the tolerances; ``False`` if none does."""
    h, w = new.shape[0], new.shape[1]
    y0, y1, x0, x1 = h, 0, w, 0
    for y in range(h):
        for x in range(w):
            changed = abs(new[y, x, 3] - shown[y, x, 3]) > tol_level
            if not changed:
                for c in range(3):
                    if abs(new[y, x, c] - shown[y, x, c]) > tol_colour:
                        changed = True
                        break
            if changed:
                y0, y1 = min(y0, y), max(y1, y + 1)
                x0, x1 = min(x0, x), max(x1, x + 1)
    box[0], box[1], box[2], box[3] = y0, y1, x0, x1
    found: bool = y1 > y0
    return found


def tile_runs(dirty: np.ndarray, most: int | None = None) -> list[tuple[int, int, int]]:
    """Runs of dirty tiles per tile row: ``(row, first column, end column)``, each at
    most ``most`` tiles long."""
    runs = []
    for ty in np.nonzero(dirty.any(axis=1))[0]:
        row = np.concatenate(([False], dirty[ty], [False]))
        edges = np.flatnonzero(row[1:] != row[:-1])
        for a, b in zip(edges[0::2], edges[1::2], strict=True):
            step = int(b - a) if most is None else most
            for c in range(int(a), int(b), step):
                runs.append((int(ty), c, min(c + step, int(b))))
    return runs


class PreviewingBrush(Protocol):
    """A brush whose stamps wait for the next step (both of the station's brushes): the
    display shows them at once through :meth:`preview` (the seam :func:`brush_preview`
    and :func:`pending_stamps` use; asked by attribute, as an ``isinstance`` check on a
    Protocol costs more than the call every frame)."""

    @property
    def pending(self) -> int: ...  # stamps waiting for the next step (cheap to ask)

    def preview(self, since: int = 0) -> StampPreview | None: ...


def brush_preview(brush: object, since: int = 0) -> StampPreview | None:
    """The brush's preview, or ``None`` for a brush that has none."""
    fn = getattr(brush, "preview", None)
    return fn(since) if fn is not None else None


def pending_stamps(brush: object) -> int:
    """Stamps the brush holds for the next step (0 for a brush without a preview)."""
    return int(getattr(brush, "pending", 0))


def _overlap(a: tuple[slice, slice], b: tuple[slice, slice]) -> bool:
    return bool(a[0].start < b[0].stop and b[0].start < a[0].stop
                and a[1].start < b[1].stop and b[1].start < a[1].stop)


def _pending_in(src: Sources, st: Any, ys: slice, xs: slice) -> dict[str, np.ndarray]:
    """The pending stamps' pigment (``src``: the brush's summed sources) on the cells
    ``[ys, xs]``, region-shaped, nothing on masked cells."""
    sy, sx = src.region
    h, w = ys.stop - ys.start, xs.stop - xs.start
    y0, y1 = max(ys.start, sy.start), min(ys.stop, sy.stop)
    x0, x1 = max(xs.start, sx.start), min(xs.stop, sx.stop)
    keep = st.mask[ys, xs] == 0
    out = {}
    for name, a in src.dp.items():
        e = np.zeros((h, w), F32)
        if y1 > y0 and x1 > x0:
            e[y0 - ys.start:y1 - ys.start, x0 - xs.start:x1 - xs.start] = \
                a[y0 - src.y0:y1 - src.y0, x0 - src.x0:x1 - src.x0]
        out[name] = e * keep
    return out


class CpuDisplay:
    """Dirty-tile rendering of a CPU canvas into a float texture (see module docstring)."""

    def __init__(self, ctx: moderngl.Context, session: Any, max_cells: int = MAX_CELLS_PER_FRAME,
                 budget_s: float = TILE_BUDGET_S) -> None:
        self.ctx = ctx
        self.max_cells = max_cells
        self.budget_s = budget_s
        self._threads = numba.get_num_threads()
        self.bind(session)

    def bind(self, session: Any) -> None:
        """Show ``session``'s canvas (a fresh painting: everything is re-rendered)."""
        self.session = session
        w, h = session.cfg.width, session.cfg.height
        old = getattr(self, "texture", None)
        if old is None or old.size != (w, h):
            if old is not None:
                old.release()
            # rgb: the cells' reflectance extended into blank cells by the paint; a: the
            # contour level (station.kiosk.subcell)
            self.texture = self.ctx.texture((w, h), 4, dtype="f4")
            self.texture.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            self.texture.repeat_x = self.texture.repeat_y = False
            # rgb: the low side's colour of hard steps inside the paint (the texture's
            # rgb holds the high side's); a: their contour level (subcell.step_fields)
            self.steps = self.ctx.texture((w, h), 4, dtype="f4")
            self.steps.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
            self.steps.repeat_x = self.steps.repeat_y = False
        # what the textures hold (nothing yet: every texel differs from +inf)
        self._shown = np.full((h, w, 4), np.inf, F32)
        self._shown_steps = np.full((h, w, 4), np.inf, F32)
        st = session.cpu_state
        self.paper_cells = st.paper_reflectance()
        self.surface = CanvasSurface.make(self.ctx, self.paper_cells, st.paper_preset, st.seed,
                                          float(st.params.paper_shade), contours=True,
                                          old=getattr(self, "surface", None))
        self.preview_box: tuple[slice, slice] | None = None  # cells showing stamps
        # cells of previews whose stamps a step took while its kernel still runs: drawn
        # anew from the state once the step is over (not from a half-written state)
        self._retired: list[tuple[slice, slice]] = []
        self._preview_steps = -1  # the step count when the preview was started
        self._previewed = 0  # pending stamps the preview shows
        # cells (y0, y1, x0, x1) uploaded since the window last composed (it empties this)
        self.damage: list[tuple[int, int, int, int]] = []
        self._carry: np.ndarray | None = None  # dirty tiles over last frame's budget
        self._owed = False  # a fresh preview's tiles marked dirty, not drawn yet
        # the pending stamps' sum and what it was summed from (:meth:`_pending_sources`)
        self._sources: tuple[tuple[int, int, int, int], Sources | None] | None = None
        self.cells_rendered = 0
        self.render_seconds = 0.0
        session.mark_all_dirty()

    def _renderer_kind(self) -> str:
        return str(getattr(self.session.canvas, "_renderer_kind", None)
                   or get_profile(self.session.player.profile).renderer)

    def update(self) -> int:
        """Re-render what changed; returns the number of cells rendered."""
        return self.update_tiles() + self.update_preview()

    def update_tiles(self) -> int:
        """Re-render the dirty tiles (what the steps changed), up to the frame's budget;
        returns the cells rendered.  The window does this before it takes the latest
        pen samples (:meth:`update_preview` shows those), so its cost does not delay
        them."""
        t0 = time.perf_counter()
        st = self.session.cpu_state
        kind = self._renderer_kind()
        ts = int(st.params.tile_size)
        self._retire_preview()
        # (the damage accumulates until the window composes it: a screenshot renders the
        # tiles in several calls before it composes, and a list reset here lost the
        # earlier calls' damage — their tiles stayed stale on screen, the stroke broken)
        if self.session.kernel_running:
            # a step's kernel is writing the state: a tile rendered now would be torn
            # (half old, half new) and its dirty mark spent — a tile that the step then
            # leaves inactive kept the torn picture, or paper where the stroke was (the
            # mock line broken on screen while the painting was whole).  The tiles wait
            # for the step's end; the pen's preview goes on meanwhile.
            self.cells_rendered = 0
            self.render_seconds = time.perf_counter() - t0
            return 0
        dirty = self.session.take_dirty()
        self._owed = False
        carried = self._carry if self._carry is not None and \
            self._carry.shape == dirty.shape else np.zeros_like(dirty)
        src = self._pending_sources() if dirty.any() | carried.any() else None
        cells = 0
        left = np.zeros_like(dirty)
        # tiles left over from the last frame first, then the new ones, up to the budget
        for ty, a, b in tile_runs(carried, RUN_TILES) + tile_runs(dirty & ~carried, RUN_TILES):
            if cells >= self.max_cells or (cells and time.perf_counter() - t0 >= self.budget_s):
                left[ty, a:b] = True
                continue
            ys = slice(ty * ts, min((ty + 1) * ts, st.height))
            xs = slice(a * ts, min(b * ts, st.width))
            # stamps not yet simulated lie here: drawn with them, as the preview draws
            # them (else the state would hide the preview until it is redone)
            pending = src if src is not None and _overlap(
                src.region, subcell.grow(ys, xs, 2 * subcell.REACH, st.height,
                                         st.width)) else None
            uy, ux = self._render_cells(st, kind, ys, xs, pending)
            if pending is not None:
                self._grow_preview(uy, ux)
            cells += (uy.stop - uy.start) * (ux.stop - ux.start)
        self._carry = left if left.any() else None
        self.cells_rendered = cells
        self.render_seconds = time.perf_counter() - t0
        return cells

    def update_preview(self) -> int:
        """Show the brush stamps made since the last step over the state; returns the
        cells rendered.  The preview stays on screen until a step takes its stamps, so
        a frame renders only where the stamps that came since the last frame lie."""
        t0 = time.perf_counter()
        st = self.session.cpu_state
        self._retire_preview()
        brush = self.session.player.brush
        if pending_stamps(brush) in (0, self._previewed):
            return 0
        pv = brush_preview(brush, self._previewed)
        if pv is None:
            return 0
        src = pv.sources
        self._sources = (self._sources_key(), src)
        fresh = not self._previewed
        box = pv.new_cells if self._previewed else src.region
        self._previewed = pv.count
        if box is None:  # the new stamps are all masked
            return 0
        if fresh and (box[0].stop - box[0].start) * (box[1].stop - box[1].start) \
                > PREVIEW_CELLS:
            self._defer(src, int(st.params.tile_size))
            self.render_seconds += time.perf_counter() - t0
            return 0
        sy, sx = src.region
        ys = slice(max(box[0].start, sy.start, 0), min(box[0].stop, sy.stop, st.height))
        xs = slice(max(box[1].start, sx.start, 0), min(box[1].stop, sx.stop, st.width))
        cells = 0
        if ys.stop > ys.start and xs.stop > xs.start:
            # (no steps' contours in the preview: their reach would more than double the
            # cells a frame renders before the pen's stamps show; the tiles draw them
            # once a step has taken the stamps)
            uy, ux = self._render_cells(st, self._renderer_kind(), ys, xs, src, steps=False)
            self._grow_preview(uy, ux)
            cells = (uy.stop - uy.start) * (ux.stop - ux.start)
        self.cells_rendered += cells
        self.render_seconds += time.perf_counter() - t0
        return cells

    def _sources_key(self) -> tuple[int, int, int, int]:
        """What the pending stamps' sum depends on: the brush, the stamps it made, how many
        it holds, the steps that took their shares (between steps stamps only come)."""
        brush = self.session.player.brush
        return (id(brush), int(getattr(brush, "stamps", 0)), pending_stamps(brush),
                int(self.session.player.counters.steps))

    def _pending_sources(self) -> Sources | None:
        """The pending stamps summed (the brush's preview's sources), kept from the last
        frame's preview while no stamp came and no step ran: summing them costs in
        proportion to the stamps pending, which grow while the sim lags behind the pen
        (2 600 stamps, up to 400 ms a sum, on a wet 1920×1080 canvas at load 8)."""
        key = self._sources_key()
        if self._sources is not None and self._sources[0] == key:
            return self._sources[1]
        pv = brush_preview(self.session.player.brush)
        src = None if pv is None else pv.sources
        self._sources = (key, src)
        return src

    def _defer(self, src: Sources, ts: int) -> None:
        """Mark dirty the tiles where ``src`` (the pending stamps, summed) puts anything:
        :meth:`update_tiles` draws them with the stamps, within its budget."""
        put = src.dw != 0
        for a in src.dp.values():
            put |= a != 0
        ys, xs = np.nonzero(put)
        ys, xs = ys + src.y0, xs + src.x0
        dirty = self.session.dirty
        h, w = dirty.shape
        inside = (ys >= 0) & (xs >= 0)
        ty, tx = ys[inside] // ts, xs[inside] // ts
        keep = (ty < h) & (tx < w)
        if not keep.any():
            return
        dirty[ty[keep], tx[keep]] = True
        self._owed = True

    def _grow_preview(self, ys: slice, xs: slice) -> None:
        pb = self.preview_box
        self.preview_box = (ys, xs) if pb is None else (
            slice(min(pb[0].start, ys.start), max(pb[0].stop, ys.stop)),
            slice(min(pb[1].start, xs.start), max(pb[1].stop, xs.stop)))

    def _retire_preview(self) -> None:
        """When a step has taken the previewed stamps (the state has them now), mark the
        preview's tiles dirty: the state is rendered there and a new preview begins."""
        steps = self.session.player.counters.steps
        n = pending_stamps(self.session.player.brush)
        if steps == self._preview_steps and n >= self._previewed:
            return
        if steps == self._preview_steps and self.session.kernel_running:
            # the step took the stamps, and its kernel is still writing them into the
            # state: the preview stays on screen until the step is over (a new preview
            # begins for the stamps that come meanwhile)
            if self.preview_box is not None:
                self._retired.append(self.preview_box)
            self.preview_box, self._previewed = None, 0
            return
        self._preview_steps, self._previewed = steps, 0
        boxes, self._retired = self._retired, []
        if self.preview_box is not None:
            boxes.append(self.preview_box)
        self.preview_box = None
        ts = int(self.session.cpu_state.params.tile_size)
        dirty = self.session.dirty
        for ys, xs in boxes:
            dirty[ys.start // ts:-(-ys.stop // ts), xs.start // ts:-(-xs.stop // ts)] = True

    def behind(self) -> bool:
        """Whether dirty tiles wait for the next frame (over this frame's budget, or a
        fresh preview's, :data:`PREVIEW_CELLS`)."""
        return self._carry is not None or self._owed

    def _render_cells(self, st: Any, kind: str, ys: slice, xs: slice,
                      pending: Sources | None, steps: bool = True) -> tuple[slice, slice]:
        """Render the cells ``[ys, xs]`` that changed (with the ``pending`` stamps'
        pigment over them) and upload what that changes in the texture: those cells
        grown by the contour level's reach (:mod:`station.kiosk.subcell`); returns the
        uploaded cells."""
        h, w = st.height, st.width
        reach, halo = (subcell.REACH, subcell.HALO) if steps else \
            (subcell.LEVEL_REACH, subcell.INDICATOR_HALO)
        uy, ux = subcell.grow(ys, xs, reach, h, w)
        ry, rx = subcell.grow(uy, ux, halo, h, w)
        extra = None if pending is None else _pending_in(pending, st, ry, rx)
        amount, pigments = region_amount(st, ry, rx, extra)
        painted = subcell.painted_cells(amount, st.r_composed[ry, rx], self.paper_cells[ry, rx])
        # the colours the extension and the steps read (the uploaded cells and their
        # halo) rendered from the same state as the indicator: colours kept from earlier
        # renders (a mirror of what was shown) disagreed with a fresher indicator along a
        # wet edge, and the extension carried a stale, darker colour out as specks and
        # notches
        ky, kx = subcell.grow(uy, ux, subcell.HALO if steps else subcell.COLOUR_HALO, h, w)
        kin = (slice(ky.start - ry.start, ky.stop - ry.start),
               slice(kx.start - rx.start, kx.stop - rx.start))
        rgb = np.zeros((ry.stop - ry.start, rx.stop - rx.start, 3), F32)
        if kind == "km":  # the amounts just taken, not a second region_amount
            rgb[kin] = self._render_km(st, ky, kx, amount[:, kin[0], kin[1]], pigments)
        else:
            k_extra = None if extra is None else {n: a[kin] for n, a in extra.items()}
            rgb[kin] = self._render(st, kind, ky, kx, k_extra)
        inner = (slice(uy.start - ry.start, uy.stop - ry.start),
                 slice(ux.start - rx.start, ux.stop - rx.start))
        ext = subcell.fields(rgb, painted, inner)
        if steps:
            hi, lo = subcell.step_fields(rgb, self.paper_cells[ry, rx], painted,
                                         ext[..., :3], inner)
            ext[..., :3] = hi
        else:  # the paint's colour on both sides: the shader's mix changes nothing
            lo = np.concatenate([ext[..., :3], np.zeros_like(ext[..., 3:])], axis=-1)
        self._upload(ext, uy, ux)
        self._upload(lo, uy, ux, steps=True)
        return uy, ux

    def _render(self, st: Any, kind: str, ys: slice, xs: slice,
                extra: dict[str, np.ndarray] | None = None) -> np.ndarray:
        # a parallel loop waits for its slowest thread: while a step's kernel holds a
        # core, or for a brush-sized region, one thread is faster than all of them
        cells = (ys.stop - ys.start) * (xs.stop - xs.start)
        before = numba.get_num_threads()  # the thread's own count (steps in the loop use it)
        numba.set_num_threads(1 if self.session.inflight or cells < SERIAL_CELLS
                              else self._threads)
        try:
            if kind == "km":  # the compiled twin of the reference (held together by tests)
                amount, pigments = region_amount(st, ys, xs, extra)
                return km_layer_fast(amount, pigments, st.r_composed[ys, xs])
            return render_region(st, kind, ys, xs, extra)
        finally:
            numba.set_num_threads(before)

    def _render_km(self, st: Any, ys: slice, xs: slice, amount: np.ndarray,
                   pigments: list[Any]) -> np.ndarray:
        """:meth:`_render` of the KM renderer from the region's amounts."""
        cells = (ys.stop - ys.start) * (xs.stop - xs.start)
        before = numba.get_num_threads()
        numba.set_num_threads(1 if self.session.inflight or cells < SERIAL_CELLS
                              else self._threads)
        try:
            return km_layer_fast(amount, pigments,
                                 st.r_composed[ys, xs])
        finally:
            numba.set_num_threads(before)

    def _upload(self, rgb: np.ndarray, ys: slice, xs: slice, steps: bool = False) -> None:
        """Upload the texels of ``rgb`` (the cells ``[ys, xs]``) that differ from what the
        texture holds (:attr:`_shown`, its mirror) by more than a fraction of a level on
        screen, and mark where the screen changes (``steps``: the steps' texture, against
        its own mirror).  A wet tile is rendered at every step,
        yet most of it is as it was (its dry cells, the rings grown round a changed
        region): 14 % of the texels rendered while painting change.  The mirror holds
        what the texture holds, so skipped changes cannot add up."""
        h, w = self.session.cfg.height, self.session.cfg.width
        data = np.ascontiguousarray(rgb, dtype=F32)
        box = np.zeros(4, np.int64)
        shown = self._shown_steps if steps else self._shown
        texture = self.steps if steps else self.texture
        if not _changed_box(data, shown[ys, xs], F32(SHOWN_COLOUR_TOL),
                            F32(SHOWN_LEVEL_TOL), box):
            return
        y0, y1, x0, x1 = (int(v) for v in box)
        cy = slice(ys.start + y0, ys.start + y1)
        cx = slice(xs.start + x0, xs.start + x1)
        part = np.ascontiguousarray(data[y0:y1, x0:x1])
        shown[cy, cx] = part
        # the screen changes wherever the shader's bicubic reads these texels: up to
        # two cells around them, however many pixels a cell covers in the view (a damage
        # margin in pixels left stale strips where the table view magnifies the cells)
        dy, dx = subcell.grow(cy, cx, subcell.BICUBIC_REACH, h, w)
        self.damage.append((dy.start, dy.stop, dx.start, dx.stop))
        texture.write(part.tobytes(), viewport=(cx.start, cy.start, cx.stop - cx.start,
                                                cy.stop - cy.start))

    def expected(self) -> np.ndarray:
        """What the texture holds once every change is drawn (float32 (H, W, 4)), made
        from scratch: the state's reference render, no pending stamps."""
        st = self.session.cpu_state
        rgb = np.asarray(self.session.canvas.render(), F32)
        pigments = st.slot_pigments()
        amount = st.p[:len(pigments)] + st.q[:len(pigments)]
        painted = subcell.painted_cells(amount, st.r_composed, self.paper_cells)
        whole = (slice(0, st.height), slice(0, st.width))
        ext = subcell.fields(rgb, painted, whole)
        hi, lo = subcell.step_fields(rgb, self.paper_cells, painted, ext[..., :3], whole)
        ext[..., :3] = hi
        self._expected_steps = lo
        return ext

    def expected_steps(self) -> np.ndarray:
        """What the steps' texture holds once every change is drawn (float32 (H, W, 4)),
        made from scratch as :meth:`expected`."""
        self.expected()
        return self._expected_steps

    def read(self) -> np.ndarray:
        """The texture's contents (float32 (H, W, 4): colour, contour level)."""
        w, h = self.texture.size
        return np.frombuffer(self.texture.read(), F32).reshape(h, w, 4)

    def read_steps(self) -> np.ndarray:
        """The steps' texture's contents (float32 (H, W, 4): the low side's colour, the
        steps' contour level)."""
        w, h = self.steps.size
        return np.frombuffer(self.steps.read(), F32).reshape(h, w, 4)

    def full_texture(self) -> moderngl.Texture:
        """A texture of the whole canvas made from scratch (:meth:`expected`; the
        reference a test holds the incremental one to)."""
        st = self.session.cpu_state
        rgba = self.expected()
        tex = self.ctx.texture((st.width, st.height), 4, np.ascontiguousarray(rgba).tobytes(),
                               dtype="f4")
        tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
        tex.repeat_x = tex.repeat_y = False
        return tex

    def full_steps(self) -> moderngl.Texture:
        """The steps' texture made from scratch (:meth:`expected_steps`)."""
        st = self.session.cpu_state
        tex = self.ctx.texture((st.width, st.height), 4,
                               np.ascontiguousarray(self.expected_steps()).tobytes(),
                               dtype="f4")
        tex.filter = (self.ctx.LINEAR, self.ctx.LINEAR)
        tex.repeat_x = tex.repeat_y = False
        return tex

    def release(self) -> None:
        self.texture.release()
        self.steps.release()
        self.surface.release()


class GpuDisplay:
    """The GL canvas's own render texture (no read-back; see module docstring)."""

    def __init__(self, ctx: moderngl.Context, session: Any) -> None:
        self.ctx = ctx
        self.bind(session)

    def bind(self, session: Any) -> None:
        self.session = session
        self.damage: list[tuple[int, int, int, int]] = []
        self.cells_rendered = 0
        self.render_seconds = 0.0
        st = session.canvas.state()  # once per painting: the paper and its grain
        self.surface = CanvasSurface.make(self.ctx, st.paper_reflectance(), st.paper_preset,
                                          st.seed, float(st.params.paper_shade),
                                          contours=True, old=getattr(self, "surface", None))
        w, h = session.cfg.width, session.cfg.height
        old = getattr(self, "fields", None)
        if old is None or old.size != (w, h):
            if old is not None:
                old.release()
            self.fields = GlFields(self.ctx, w, h)
        self._render()

    def _render(self) -> None:
        """The canvas's render pass, then its sub-cell fields (the texture the window
        samples: colour extended by the paint, the contour level)."""
        rgb = self.session.canvas.render_texture()
        self.texture = self.fields.run(self.session.canvas, rgb, self.surface.paper)
        #: the hard steps' low side and contour level (:class:`GlFields`)
        self.steps: moderngl.Texture | None = self.fields.steps

    def full_texture(self) -> moderngl.Texture:
        """The canvas's own render texture (the GPU renders it whole every frame)."""
        return self.texture

    def full_steps(self) -> moderngl.Texture | None:
        """The steps' texture (rendered whole every frame, as :meth:`full_texture`)."""
        return self.steps

    def behind(self) -> bool:
        """The GPU renders the whole canvas every frame: never behind."""
        return False

    def update(self) -> int:
        return self.update_tiles() + self.update_preview()

    def update_tiles(self) -> int:
        """Nothing before the pen's latest samples: the GPU renders the whole canvas."""
        self.damage = []
        self.cells_rendered = 0
        self.render_seconds = 0.0
        return 0

    def update_preview(self) -> int:
        """The pending stamps into the canvas and the canvas's render pass."""
        t0 = time.perf_counter()
        # pending stamps go in now: on the GPU the sources pass is cheap and the preview
        # would need the state on the CPU
        self.session.player.flush_sources()
        self.session.take_dirty()
        self._render()
        self.ctx.memory_barrier()  # image stores → texture fetches of the window's shader
        w, h = self.session.cfg.width, self.session.cfg.height
        self.damage = [(0, h, 0, w)]  # the whole canvas may have changed
        self.cells_rendered = w * h
        self.render_seconds = time.perf_counter() - t0
        return self.cells_rendered

    def release(self) -> None:
        """The canvas's render texture is the canvas's; the fields and paper are ours."""
        self.fields.release()
        self.surface.release()


class CanvasSurface:
    """The paper under the paint, as textures for the window's shader: the cells' bare
    reflectance and the sub-cell grain (:mod:`station.kiosk.subcell`)."""

    def __init__(self, paper: moderngl.Texture, grain: moderngl.Texture, shade: float,
                 contours: bool, key: tuple[str, int, int, int]) -> None:
        self.paper = paper
        self.grain = grain
        self.shade = shade
        self.contours = contours
        self.key = key

    @classmethod
    def make(cls, ctx: moderngl.Context, paper_cells: np.ndarray, preset: str, seed: int,
             shade: float, contours: bool, old: CanvasSurface | None = None) -> CanvasSurface:
        """The surface of a painting (``old``'s textures kept when the paper is the same:
        a fresh canvas of the same size and seed)."""
        h, w = paper_cells.shape
        key = (preset, seed, w, h)
        if old is not None and old.key == key:
            old.contours, old.shade = contours, shade
            return old
        if old is not None:
            old.release()
        paper = ctx.texture((w, h), 1, np.ascontiguousarray(paper_cells, F32).tobytes(),
                            dtype="f4")
        paper.filter = (ctx.LINEAR, ctx.LINEAR)
        paper.repeat_x = paper.repeat_y = False
        patch = subcell.grain_patch(preset, seed)
        grain = ctx.texture((patch.shape[1], patch.shape[0]), 1, patch.tobytes(), dtype="f4")
        grain.filter = (ctx.LINEAR, ctx.LINEAR)
        return cls(paper, grain, shade, contours, key)

    def use(self, prog: Any, first_unit: int) -> None:
        """Bind the textures from ``first_unit`` on and set the shader's uniforms."""
        self.paper.use(first_unit)
        self.grain.use(first_unit + 1)
        prog["paper"].value = first_unit
        prog["grain"].value = first_unit + 1
        prog["grain_k"].value = float(subcell.GRAIN_K)
        prog["grain_texels"].value = float(self.grain.size[0])
        prog["shade"].value = self.shade * subcell.GRAIN_GAIN
        prog["granulation"].value = subcell.GRANULATION
        prog["contours"].value = self.contours

    def release(self) -> None:
        self.paper.release()
        self.grain.release()


def make_display(ctx: moderngl.Context, session: Any) -> CpuDisplay | GpuDisplay:
    if session.cpu_state is not None:
        return CpuDisplay(ctx, session)
    return GpuDisplay(ctx, session)
