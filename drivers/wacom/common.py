"""What the Wacom protocol parsers need to know about a model (from its device data)."""

from __future__ import annotations

from dataclasses import dataclass, field

from station.drivers.devicedata import DeviceModel
from station.drivers.hid.errors import ReportError
from station.drivers.raw import Axis


@dataclass(frozen=True, slots=True)
class WacomParams:
    """Per-model constants.

    Attributes:
        max_x, max_y: largest coordinates (device units).
        max_pressure: largest pressure (device units).
        max_distance: largest hover distance (device units).
        resolution: units per mm (x and y).
        skip_report_ids: report IDs on the pen interface that are not pen
            reports (mouse mode, pad keys): skipped and counted.
    """

    max_x: int
    max_y: int
    max_pressure: int
    max_distance: int
    resolution: float
    resolution_y: float
    skip_report_ids: frozenset[int] = field(default_factory=frozenset)

    @classmethod
    def from_model(cls, model: DeviceModel) -> WacomParams:
        res = model.get("resolution", {})
        skip = {1}  # mouse-mode reports (report ID 1) before the pen-mode switch
        skip.update(model.get("pad_report_ids", []))
        return cls(
            max_x=int(model["max_x"]),
            max_y=int(model["max_y"]),
            max_pressure=int(model["max_pressure"]),
            max_distance=int(model.get("max_distance", 0)),
            resolution=float(res.get("x", 0)) or 0.0,
            resolution_y=float(res.get("y", 0)) or 0.0,
            skip_report_ids=frozenset(skip),
        )

    def x_axis(self) -> Axis:
        return Axis(0, self.max_x, self.resolution or None)

    def y_axis(self) -> Axis:
        return Axis(0, self.max_y, self.resolution_y or None)


def check_length(report: bytes, allowed: tuple[int, ...], what: str) -> None:
    if len(report) not in allowed:
        contiguous = len(allowed) > 2 and list(allowed) == list(range(allowed[0], allowed[-1] + 1))
        want = f"{allowed[0]}..{allowed[-1]}" if contiguous else " or ".join(map(str, allowed))
        raise ReportError(f"{what} report {report[0]} is {len(report)} bytes, expected {want}")


def unknown_id(report: bytes, what: str) -> ReportError:
    return ReportError(f"unknown {what} report ID {report[0]}")
