"""The pigment palette: Kubelka-Munk coefficients and surface-layer properties.

K (absorption, sigma_a) and S (scattering, sigma_s) per RGB channel come from the
packaged copy of the Curtis 1997 table (``station/data/palette-curtis.csv``, seed
table 6.1); staining beta, granulation gamma and density delta come from the
station's own table ``station/data/pigment-properties.csv``, which also carries
the extra pigments (a gouache white and an ink black) with their K and S.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Any

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

    def __post_init__(self) -> None:
        vals = (*self.K, *self.S)
        if len(self.K) != 3 or len(self.S) != 3 or any(v < 0 for v in vals):
            raise CanvasInputError(f"pigment {self.name!r}: K and S need 3 values >= 0")
        if min(self.S) <= 0:
            raise CanvasInputError(f"pigment {self.name!r}: S must be > 0")
        if self.beta <= 0 or not 0 <= self.gamma <= 1 or not 0 <= self.delta <= 1:
            raise CanvasInputError(
                f"pigment {self.name!r}: need beta > 0, gamma and delta in [0, 1]"
            )

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "K": list(self.K), "S": list(self.S),
                "beta": self.beta, "gamma": self.gamma, "delta": self.delta}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Pigment:
        try:
            return cls(str(d["name"]), tuple(float(x) for x in d["K"]),  # type: ignore[arg-type]
                       tuple(float(x) for x in d["S"]),  # type: ignore[arg-type]
                       float(d["beta"]), float(d["gamma"]), float(d["delta"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise CanvasInputError(f"malformed pigment entry: {exc}") from None


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
        ))
    return Palette(pigments)


def load_palette() -> Palette:
    """The packaged palette (alias of :func:`default_palette`)."""
    return default_palette()
