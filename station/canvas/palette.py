"""The pigment palette: Kubelka-Munk coefficients and surface-layer properties.

K (absorption, sigma_a) and S (scattering, sigma_s) per RGB channel come from the
packaged copy of the Curtis 1997 table (``station/data/palette-curtis.csv``, seed
table 6.1); staining beta, granulation gamma and density delta come from the
station's own table ``station/data/pigment-properties.csv``, which also carries
the extra pigments (a gouache white and an ink black) with their K and S.

The spectral renderer's K(λ), S(λ) in :data:`N_BANDS` bands come from
``station/data/spectral-palette.json`` (written by ``tools/gen_spectral_palette.py``: a
physical absorption model per pigment fitted to the RGB appearance of its Curtis K and
S); a pigment without spectra (a user profile's) is upsampled from its RGB values with
:func:`upsample_rgb`.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Any

import numpy as np

from station.canvas.errors import CanvasInputError


@dataclass(frozen=True)
class Pigment:
    """One pigment.

    K, S: Kubelka-Munk absorption and scattering per RGB channel [1/thickness],
    beta: staining (> 0, lifting is divided by it), gamma: granulation in [0, 1],
    delta: density in [0, 1].
    """

    name: str
    K: tuple[float, float, float]
    S: tuple[float, float, float]
    beta: float
    gamma: float
    delta: float
    K_spec: tuple[float, ...] = ()
    """absorption per spectral band (:data:`N_BANDS` values) or () for RGB upsampling"""
    S_spec: tuple[float, ...] = ()
    """scattering per spectral band, as ``K_spec``"""

    def __post_init__(self) -> None:
        vals = (*self.K, *self.S, *self.K_spec, *self.S_spec)
        if len(self.K) != 3 or len(self.S) != 3 or any(v < 0 for v in vals):
            raise CanvasInputError(f"pigment {self.name!r}: K and S need 3 values >= 0")
        if min(self.S) <= 0 or (self.S_spec and min(self.S_spec) <= 0):
            raise CanvasInputError(f"pigment {self.name!r}: S must be > 0")
        if {len(self.K_spec), len(self.S_spec)} not in ({0}, {N_BANDS}):
            raise CanvasInputError(
                f"pigment {self.name!r}: K_spec and S_spec need {N_BANDS} values each")
        if self.beta <= 0 or not 0 <= self.gamma <= 1 or not 0 <= self.delta <= 1:
            raise CanvasInputError(
                f"pigment {self.name!r}: need beta > 0, gamma and delta in [0, 1]"
            )

    def spectra(self) -> tuple[np.ndarray, np.ndarray]:
        """K(λ), S(λ) per band (float32 (N_BANDS,) each): the table's, else upsampled."""
        if self.K_spec:
            return np.array(self.K_spec, np.float32), np.array(self.S_spec, np.float32)
        return upsample_rgb(self.K), upsample_rgb(self.S)

    def to_dict(self) -> dict[str, object]:
        d: dict[str, object] = {"name": self.name, "K": list(self.K), "S": list(self.S),
                             "beta": self.beta, "gamma": self.gamma, "delta": self.delta}
        if self.K_spec:
            d.update(K_spec=list(self.K_spec), S_spec=list(self.S_spec))
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Pigment:
        try:
            return cls(str(d["name"]), tuple(float(x) for x in d["K"]),  # type: ignore[arg-type]
                       tuple(float(x) for x in d["S"]),  # type: ignore[arg-type]
                       float(d["beta"]), float(d["gamma"]), float(d["delta"]),
                       tuple(float(x) for x in d.get("K_spec", ())),
                       tuple(float(x) for x in d.get("S_spec", ())))
        except (KeyError, TypeError, ValueError) as exc:
            raise CanvasInputError(f"malformed pigment entry: {exc}") from None


@dataclass(frozen=True)
class SpectralTable:
    """``station/data/spectral-palette.json``: band edges [nm], the (3, N_BANDS) matrix
    from band reflectance to linear sRGB (rows sum to 1: a flat spectrum is grey), and
    per pigment name its K(λ), S(λ) [1/thickness]."""

    edges_nm: tuple[float, ...]
    to_rgb: np.ndarray
    pigments: dict[str, tuple[tuple[float, ...], tuple[float, ...]]]


N_BANDS = 12
"""Spectral bands of the KM render (25 nm each over 400-700 nm)."""


@lru_cache(maxsize=1)
def spectral_table() -> SpectralTable:
    """The packaged spectral table (validated: N_BANDS bands, finite, K >= 0, S > 0)."""
    data = json.loads(_read_data("spectral-palette.json"))
    m = np.array(data["band_to_linear_srgb"], np.float32)
    pigs = {p["name"]: (tuple(float(v) for v in p["K"]), tuple(float(v) for v in p["S"]))
            for p in data["pigments"]}
    if m.shape != (3, N_BANDS) or len(data["band_edges_nm"]) != N_BANDS + 1 or any(
            len(k) != N_BANDS or len(s) != N_BANDS or min(k) < 0 or min(s) <= 0
            for k, s in pigs.values()):
        raise CanvasInputError("spectral-palette.json: malformed table")
    m.setflags(write=False)
    return SpectralTable(tuple(float(v) for v in data["band_edges_nm"]), m, pigs)


def upsample_rgb(rgb: tuple[float, ...]) -> np.ndarray:
    """A smooth spectrum for a pigment known only by RGB K or S (a user profile's):
    blue's value below 480 nm, green's over 510-570 nm, red's above 600 nm, linear
    ramps between (float32 (N_BANDS,)). Flat RGB gives a flat spectrum."""
    edges = np.linspace(400.0, 700.0, N_BANDS + 1)
    lam = 0.5 * (edges[:-1] + edges[1:])
    blue = np.clip((510.0 - lam) / 30.0, 0.0, 1.0)
    red = np.clip((lam - 570.0) / 30.0, 0.0, 1.0)
    green = 1.0 - blue - red
    return (red * rgb[0] + green * rgb[1] + blue * rgb[2]).astype(np.float32)


def _rows(text: str) -> Iterator[dict[str, str]]:
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    yield from csv.DictReader(io.StringIO("\n".join(lines)))


def _read_data(name: str) -> str:
    return resources.files("station").joinpath("data", name).read_text(encoding="utf-8")


class Palette:
    """An ordered collection of pigments looked up by name (case-insensitive)."""

    def __init__(self, pigments: Iterable[Pigment]) -> None:
        self._by_key: dict[str, Pigment] = {}
        for p in pigments:
            self._by_key[p.name.casefold()] = p

    def __len__(self) -> int:
        return len(self._by_key)

    def __iter__(self) -> Iterator[Pigment]:
        return iter(self._by_key.values())

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name.casefold() in self._by_key

    def names(self) -> list[str]:
        return [p.name for p in self._by_key.values()]

    def get(self, name: str) -> Pigment:
        """The pigment called ``name``; unknown names raise :class:`CanvasInputError`."""
        try:
            return self._by_key[name.casefold()]
        except (KeyError, AttributeError):
            raise CanvasInputError(
                f"unknown pigment {name!r} (known: {', '.join(self.names())})", "pigment"
            ) from None


@lru_cache(maxsize=1)
def default_palette() -> Palette:
    """The packaged palette: the Curtis table plus the station's extra pigments."""
    props = {r["name"]: r for r in _rows(_read_data("pigment-properties.csv"))}
    spec = spectral_table().pigments
    pigments: list[Pigment] = []
    seen: set[str] = set()
    for r in _rows(_read_data("palette-curtis.csv")):
        pr = props.get(r["name"])
        if pr is None:
            raise CanvasInputError(f"pigment {r['name']!r} has no properties row")
        pigments.append(Pigment(
            r["name"],
            (float(r["K_r"]), float(r["K_g"]), float(r["K_b"])),
            (float(r["S_r"]), float(r["S_g"]), float(r["S_b"])),
            float(pr["beta"]), float(pr["gamma"]), float(pr["delta"]),
            *spec.get(r["name"], ((), ())),
        ))
        seen.add(r["name"])
    for name, pr in props.items():
        if name in seen:
            continue
        pigments.append(Pigment(
            name,
            (float(pr["K_r"]), float(pr["K_g"]), float(pr["K_b"])),
            (float(pr["S_r"]), float(pr["S_g"]), float(pr["S_b"])),
            float(pr["beta"]), float(pr["gamma"]), float(pr["delta"]),
            *spec.get(name, ((), ())),
        ))
    return Palette(pigments)


def load_palette() -> Palette:
    """The packaged palette (alias of :func:`default_palette`)."""
    return default_palette()
