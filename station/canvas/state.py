"""The complete canvas state: plain float32 arrays plus JSON-able metadata.

Array fields (float32, shape (H, W) unless noted):

- fluid layer: ``vx``, ``vy`` [cell/s], ``w`` [height], ``p`` (S, H, W) [area fraction];
- surface layer: ``q`` (S, H, W) [area fraction];
- capillary layer: ``wc`` [height];
- paper: ``h`` in [0, 1] (capacity is derived: ``c = c_min + h (c_max - c_min)``);
  ``fibre`` (2, H, W) in [0, 1], the fibre texture (along x, along y) of the paper
  preset (``paper.make_fibres``; static, regenerated from preset and seed when a saved
  state lacks it);
- wet phase: ``wet_area`` in [0, 1], Curtis 1997's wet-area mask ``M`` with a memory
  (``SimParams.wet_hold``): 1 where the cell holds its own water, fading after the water
  has gone while the paper is damp, 0 on dry paper (all 0 when ``wet_hold`` is 0; a saved
  state without it loads with zeros);
- tools: ``mask`` in {0, 1}; ``block`` in [0, 1] (1 = free) with ``block_time``, the
  simulated time [s] at which the pattern was written (its age is ``sim_time -
  block_time``; storing the write time instead of an age keeps the field static
  outside active tiles, so tiling cannot change the result);
- passive: ``r_composed`` (H, W, B), the reflectance of all dried layers below per render
  band (B = ``params.render_bands``: 12 spectral bands, or 3 RGB channels);
- bookkeeping accumulators, updated inside the passes: ``evaporated`` (water that
  left by evaporation, fluid and capillary; backends fold it into the float64 total
  ``evaporated_folded`` every ``FOLD_EVERY`` steps so float32 per-cell sums stay small
  and precise), ``removed_w`` (water removed by tools),
  ``removed_p`` (S, H, W) (pigment removed by tools);
- ``tile_ttl`` (int32, tiles_y x tiles_x): steps each dirty tile stays active.

Pigment slots: ``slots[k]`` names the pigment held in ``p[k]``/``q[k]`` of the active
layer; slots are assigned on first use; ``new_layer`` frees them.
"""

from __future__ import annotations

import io
import json
import zipfile
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from station.canvas.palette import Palette, Pigment, default_palette
from station.canvas.paper import make_fibres
from station.canvas.params import CanvasInputError, SimParams
from station.canvas.profiles import get_profile
from station.durable import atomic_write

STATE_VERSION = 1
DEFAULT_SLOTS = 8
MAX_CELLS = 1 << 24  # 16 Mcells (4096^2): larger canvases are refused as impossible

_PLANE_FIELDS = ("vx", "vy", "w", "wc", "h", "mask", "block", "block_time",
                 "evaporated", "removed_w")
_STACK_FIELDS = ("p", "q", "removed_p")

ARRAY_FIELDS = (*_PLANE_FIELDS, *_STACK_FIELDS, "r_composed", "fibre", "wet_area", "tile_ttl")
"""Every array field of a :class:`CanvasState`."""

STEP_FIELDS = frozenset({"vx", "vy", "w", "wc", "p", "q", "evaporated", "wet_area",
                         "tile_ttl", "removed_w", "removed_p"})
"""The arrays a live step may write: its brush sources (``w``, ``p``, ``vx``, ``vy``,
``tile_ttl``), the round brush's beads (and ``wet_area``), a deformable brush's pick-ups
(``q``, ``removed_w``, ``removed_p``), the hair dryer (``wc``, ``evaporated``), the kernel
and the accumulators' fold.  The others (the paper ``h`` and ``fibre``, ``mask``,
``block``, ``block_time``, the dried layers' ``r_composed``) change only by a command or a
tool's dab, so
an undo checkpoint may share them with the live canvas until one comes (the kiosk's
deferred checkpoints, :mod:`station.kiosk.session`); ``tests/test_kiosk_checkpoints.py``
holds every step writer to this list."""


def check_size(width: int, height: int) -> None:
    """Raise :class:`CanvasInputError` for an impossible canvas size."""
    if (not isinstance(width, (int, np.integer)) or not isinstance(height, (int, np.integer))
            or isinstance(width, bool) or isinstance(height, bool)):
        raise CanvasInputError("canvas size must be integers", "--size")
    if width < 4 or height < 4:
        raise CanvasInputError(f"canvas size {width}x{height} is too small (min 4x4)", "--size")
    if width * height > MAX_CELLS:
        raise CanvasInputError(
            f"canvas size {width}x{height} exceeds {MAX_CELLS} cells", "--size")


@dataclass
class CanvasState:
    """Everything needed to continue a painting exactly (see module docstring)."""

    width: int
    height: int
    params: SimParams
    palette: Palette
    profile: str
    paper_preset: str
    seed: int
    vx: np.ndarray
    vy: np.ndarray
    w: np.ndarray
    wc: np.ndarray
    h: np.ndarray
    mask: np.ndarray
    block: np.ndarray
    block_time: np.ndarray
    p: np.ndarray
    q: np.ndarray
    r_composed: np.ndarray
    evaporated: np.ndarray
    removed_w: np.ndarray
    removed_p: np.ndarray
    tile_ttl: np.ndarray
    slots: list[str] = field(default_factory=list)
    step_count: int = 0
    sim_time: float = 0.0
    tiling: bool = True
    water_added: float = 0.0
    evaporated_folded: float = 0.0
    pigment_added: dict[str, float] = field(default_factory=dict)
    pigment_removed_past: dict[str, float] = field(default_factory=dict)
    pigment_dried: dict[str, float] = field(default_factory=dict)
    layers: list[dict[str, float]] = field(default_factory=list)
    fibre: np.ndarray = field(default_factory=lambda: np.zeros((2, 0, 0), np.float32))
    wet_area: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), np.float32))

    def __post_init__(self) -> None:
        if self.fibre.shape != (2, self.height, self.width):
            self.fibre = make_fibres(self.paper_preset, self.height, self.width, self.seed)
        if self.wet_area.shape != (self.height, self.width):
            self.wet_area = np.zeros((self.height, self.width), np.float32)

    # ----------------------------------------------------------------- creation
    @classmethod
    def blank(cls, width: int, height: int, params: SimParams, h: np.ndarray,
              profile: str = "watercolor", paper_preset: str = "cold-press", seed: int = 0,
              palette: Palette | None = None, n_slots: int = DEFAULT_SLOTS,
              tiling: bool = True) -> CanvasState:
        """A clean sheet of paper ``h`` (float32 (H, W) in [0, 1])."""
        check_size(width, height)
        if h.shape != (height, width):
            raise CanvasInputError("paper height has the wrong shape")
        if n_slots < 1:
            raise CanvasInputError("need at least one pigment slot")
        z = np.zeros((height, width), np.float32)
        ts = int(params.tile_size)
        ty, tx = -(-height // ts), -(-width // ts)
        st = cls(
            width=width, height=height, params=params,
            palette=palette if palette is not None else default_palette(),
            profile=profile, paper_preset=paper_preset, seed=int(seed),
            vx=z.copy(), vy=z.copy(), w=z.copy(), wc=z.copy(),
            h=np.ascontiguousarray(h, np.float32), mask=z.copy(),
            block=np.ones_like(z), block_time=z.copy(),
            p=np.zeros((n_slots, height, width), np.float32),
            q=np.zeros((n_slots, height, width), np.float32),
            r_composed=np.zeros((height, width, int(params.render_bands)), np.float32),
            evaporated=z.copy(), removed_w=z.copy(),
            removed_p=np.zeros((n_slots, height, width), np.float32),
            tile_ttl=np.zeros((ty, tx), np.int32), tiling=tiling,
        )
        st.r_composed[...] = st.paper_reflectance()[..., None]
        return st

    @property
    def n_slots(self) -> int:
        return int(self.p.shape[0])

    def capacity(self) -> np.ndarray:
        """Capillary capacity ``c = c_min + h (c_max - c_min)`` [height], float32 (H, W)."""
        prm = self.params
        return np.float32(prm.c_min) + self.h * np.float32(prm.c_max - prm.c_min)

    def paper_reflectance(self) -> np.ndarray:
        """Blank paper reflectance (valleys slightly darker), float32 (H, W)."""
        return (np.float32(1.0) - np.float32(self.params.paper_shade) * (1.0 - self.h)).astype(
            np.float32)

    def slot_of(self, name: str, create: bool = True) -> int:
        """Slot index of pigment ``name`` in the active layer (assigned on first use).

        Raises :class:`CanvasInputError` for an unknown pigment, or when the layer
        already holds ``n_slots`` other pigments ("start a new layer").
        """
        pig = self.palette.get(name)
        if pig.name in self.slots:
            return self.slots.index(pig.name)
        if not create:
            raise CanvasInputError(f"pigment {name!r} is not in the active layer")
        if len(self.slots) >= self.n_slots:
            raise CanvasInputError(
                f"the active layer already holds {self.n_slots} pigments "
                f"({', '.join(self.slots)}); start a new layer to use {pig.name!r}", "pigment")
        self.slots.append(pig.name)
        return len(self.slots) - 1

    def slot_pigments(self) -> list[Pigment]:
        return [self.palette.get(n) for n in self.slots]

    def copy(self) -> CanvasState:
        """A deep copy (arrays copied)."""
        kw: dict[str, Any] = {}
        for name in self.__dataclass_fields__:
            v = getattr(self, name)
            if isinstance(v, np.ndarray):
                v = v.copy()
            elif isinstance(v, (list, dict)):
                v = json.loads(json.dumps(v))
            kw[name] = v
        return CanvasState(**kw)

    # ------------------------------------------------------------------ save/load
    def metadata(self) -> dict[str, object]:
        return {
            "format": "station-canvas", "version": STATE_VERSION,
            "width": self.width, "height": self.height, "n_slots": self.n_slots,
            "params": self.params.to_dict(), "palette": [p.to_dict() for p in self.palette],
            "profile": self.profile, "paper_preset": self.paper_preset, "seed": self.seed,
            "slots": list(self.slots), "step_count": self.step_count,
            "sim_time": self.sim_time, "tiling": self.tiling,
            "water_added": self.water_added, "evaporated_folded": self.evaporated_folded,
            "pigment_added": self.pigment_added,
            "pigment_removed_past": self.pigment_removed_past,
            "pigment_dried": self.pigment_dried, "layers": self.layers,
        }

    def save(self, path: str | Path) -> None:
        """Write the state losslessly to ``path`` (.npz with a JSON ``meta`` entry).

        Pigment planes are stored for the used slots only (the others are zero by
        construction) and the archive is zlib-compressed: a mostly blank canvas is small.
        The file is replaced atomically: a crash or a full disk leaves the old one.
        """
        atomic_write(path, self.npz_bytes())

    def npz_bytes(self, extra: Mapping[str, object] | None = None,
                  quick: bool = False) -> bytes:
        """The .npz archive :meth:`save` writes; ``extra`` adds JSON entries (a live
        session's checkpoint data), which :meth:`load` ignores and
        :func:`read_extra` returns.  ``quick`` (a live session's autosave): the arrays
        that hardly compress are stored, the rest deflated at level 1
        (:func:`quick_npz`): at 1920×1080 wet ~1 s against 8 s, 80 against 74 MiB."""
        used = len(self.slots)
        arrays = {n: getattr(self, n) for n in _PLANE_FIELDS}
        arrays.update({n: getattr(self, n)[:used] for n in _STACK_FIELDS})
        arrays["r_composed"] = self.r_composed
        arrays["fibre"] = self.fibre
        arrays["wet_area"] = self.wet_area
        arrays["tile_ttl"] = self.tile_ttl
        meta = np.array(json.dumps(self.metadata()))
        arrays["meta"] = meta
        arrays.update({f"extra_{k}": np.array(json.dumps(v)) for k, v in (extra or {}).items()})
        if quick:
            return quick_npz(arrays)
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        return buf.getvalue()

    @classmethod
    def load(cls, path: str | Path) -> CanvasState:
        """Read a state written by :meth:`save`; anything malformed raises CanvasInputError."""
        where = str(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                files = {k: z[k] for k in z.files}
        except FileNotFoundError:
            raise CanvasInputError("state file not found", where) from None
        except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
            raise CanvasInputError(f"corrupt state file ({exc.__class__.__name__})",
                                   where) from None
        try:
            meta = json.loads(str(files.pop("meta")))
        except (KeyError, ValueError) as exc:
            raise CanvasInputError(f"state file has no valid metadata ({exc})", where) from None
        if not isinstance(meta, dict) or meta.get("format") != "station-canvas":
            raise CanvasInputError("not a station canvas state", where)
        if meta.get("version") != STATE_VERSION:
            raise CanvasInputError(f"unsupported state version {meta.get('version')!r}", where)
        try:
            width, height, ns = int(meta["width"]), int(meta["height"]), int(meta["n_slots"])
            check_size(width, height)
            params = SimParams.from_dict(meta["params"])
            palette = Palette(Pigment.from_dict(d) for d in meta["palette"])
            profile = str(meta["profile"])
            get_profile(profile)
            ts = int(params.tile_size)
            shapes: dict[str, tuple[int, ...]] = {n: (height, width) for n in _PLANE_FIELDS}
            slots = [str(s) for s in meta["slots"]]
            if len(slots) > ns:
                raise CanvasInputError("more slots than pigment planes", where)
            shapes.update({n: (len(slots), height, width) for n in _STACK_FIELDS})
            rc = files.get("r_composed")
            if rc is not None and rc.ndim == 3 and rc.shape[2] == 3 != params.render_bands:
                params = params.replace(render_bands=3)  # a state from the RGB renderer
            shapes["r_composed"] = (height, width, int(params.render_bands))
            shapes["tile_ttl"] = (-(-height // ts), -(-width // ts))
            arrays: dict[str, np.ndarray] = {}
            for name, shape in shapes.items():
                a = files.get(name)
                want = np.int32 if name == "tile_ttl" else np.float32
                if a is None or a.shape != shape or a.dtype != want:
                    raise CanvasInputError(f"field {name!r} missing or mismatched", where)
                if a.dtype == np.float32 and not np.isfinite(a).all():
                    raise CanvasInputError(f"field {name!r} holds non-finite values", where)
                arrays[name] = np.ascontiguousarray(a)
            for name in _STACK_FIELDS:  # free slots are zero
                full = np.zeros((ns, height, width), np.float32)
                full[: len(slots)] = arrays[name]
                arrays[name] = full
            for s in slots:
                palette.get(s)
            fib = files.get("fibre")  # optional: older states regenerate it (same seed)
            if (fib is not None and fib.shape == (2, height, width) and fib.dtype == np.float32
                    and np.isfinite(fib).all()):
                arrays["fibre"] = np.ascontiguousarray(fib)
            area = files.get("wet_area")  # optional: older states start with no wet memory
            if area is not None:
                if (area.shape != (height, width) or area.dtype != np.float32
                        or not np.isfinite(area).all()):
                    raise CanvasInputError("field 'wet_area' mismatched", where)
                arrays["wet_area"] = np.ascontiguousarray(area)
            st = cls(
                width=width, height=height, params=params, palette=palette, profile=profile,
                paper_preset=str(meta["paper_preset"]), seed=int(meta["seed"]),
                slots=slots, step_count=int(meta["step_count"]),
                sim_time=float(meta["sim_time"]), tiling=bool(meta["tiling"]),
                water_added=float(meta["water_added"]),
                evaporated_folded=float(meta.get("evaporated_folded", 0.0)),
                pigment_added={str(k): float(v) for k, v in meta["pigment_added"].items()},
                pigment_removed_past={str(k): float(v)
                                      for k, v in meta["pigment_removed_past"].items()},
                pigment_dried={str(k): float(v) for k, v in meta["pigment_dried"].items()},
                layers=[{str(k): float(v) for k, v in d.items()} for d in meta["layers"]],
                **arrays,
            )
        except CanvasInputError:
            raise
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise CanvasInputError(f"state metadata is malformed ({exc})", where) from None
        return st


#: Bytes of an array that :func:`quick_npz` deflates to see whether it compresses.
PROBE_BYTES = 1 << 18
#: An array whose probe deflates to more than this share of its size is stored as is:
#: velocities, water and pigment planes of a wet canvas (float noise) deflate to ~0.8-0.9
#: at five times the time of the rest together.
STORE_ABOVE = 0.7


def quick_npz(arrays: Mapping[str, np.ndarray]) -> bytes:
    """An .npz archive (what ``np.load`` reads) of ``arrays``, each stored or deflated at
    level 1 as a probe of its first :data:`PROBE_BYTES` says (:data:`STORE_ABOVE`)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as z:
        for name, value in arrays.items():
            a = np.asanyarray(value)  # (0-d kept: the metadata's JSON string)
            probe = a.reshape(-1)[:max(1, PROBE_BYTES // max(a.itemsize, 1))].tobytes()
            stored = len(probe) >= 4096 and (
                len(zlib.compress(probe, 1)) > STORE_ABOVE * len(probe))
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_STORED if stored else zipfile.ZIP_DEFLATED
            # (Python 3.13 names it compress_level: a property over this one)
            setattr(info, "_compresslevel", 1)  # noqa: B010 (a ZipInfo passed to open
            # would deflate at zlib's default level 6)
            with z.open(info, "w", force_zip64=True) as f:
                np.lib.format.write_array(f, a, allow_pickle=False)
    return buf.getvalue()


def read_extra(path: str | Path, name: str) -> object:
    """The JSON entry ``name`` that :meth:`CanvasState.npz_bytes` added, or ``None``."""
    where = str(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            key = f"extra_{name}"
            if key not in z.files:
                return None
            return json.loads(str(z[key]))
    except FileNotFoundError:
        raise CanvasInputError("state file not found", where) from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise CanvasInputError(f"corrupt state file ({exc.__class__.__name__})", where) from None
