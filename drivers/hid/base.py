"""The report-parser interface every protocol parser implements.

A :class:`ReportParser` turns the input reports of one interface into
:class:`station.drivers.raw.RawSample` values.  It is pure: it never touches
hardware; where the protocol is stateful (the Wacom Intuos tool identity)
the state lives in the parser object.
"""

from __future__ import annotations

from collections import Counter

from station.drivers.devicedata import DeviceModel
from station.drivers.hid.errors import ReportError
from station.drivers.raw import AxisRanges, RawSample


class ReportParser:
    """Base of all parsers.

    Attributes:
        name: parser name as used in device data (``"wacom-intuos"``, ``"hid-generic"`` …).
        model: the device data dict, or ``None`` for an unknown device.
        generic: True when an unknown (or descriptor-only) device is served from
            its report descriptor.
        ranges: the pen axes in device units.
        init_features: feature reports to send when the interface is opened
            (e.g. the Wacom mouse-mode switch ``02 02``).
        is_pen: False for interfaces that carry no pen (touch, pad): callers ignore them.
        kind: ``"pen"``, ``"touch"``, ``"pad"`` or ``"other"``.
        skipped: reports recognised as not pen (touch, pad, mouse mode …), counted.
        skipped_by_kind: the same count by kind.
        skipped_by_id: the same count by report ID.
        unused_report_ids: report IDs the interface's descriptor declares that the
            protocol does not use (the kernel's Wacom handlers ignore them): skipped and
            counted as kind ``"unused"``, never bad.  Set by the registry.
        dropped: pen reports that carried no usable sample (e.g. data before
            the tool was identified), counted.
    """

    name: str = "base"

    def __init__(
        self,
        ranges: AxisRanges,
        model: DeviceModel | None = None,
        init_features: list[bytes] | None = None,
        generic: bool = False,
        is_pen: bool = True,
        kind: str = "pen",
    ) -> None:
        self.ranges = ranges
        self.model = model
        self.init_features = list(init_features or [])
        self.generic = generic
        self.is_pen = is_pen
        self.kind = kind
        self.skipped = 0
        self.skipped_by_kind: Counter[str] = Counter()
        self.skipped_by_id: Counter[int] = Counter()
        self.unused_report_ids: frozenset[int] = frozenset()
        self.dropped = 0
        # Set when the device is served by a fallback (unknown id): what and how to report it.
        self.warning: str | None = None

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        """Parse one input report received at ``time`` (seconds, transport clock).

        Returns the pen samples it carries (empty for reports that are not pen
        reports — counted in :attr:`skipped`); raises
        :class:`station.drivers.hid.errors.ReportError` for malformed reports.
        """
        raise NotImplementedError

    def reset(self) -> None:
        """Forget protocol state (the tool in proximity); called when the device reopens."""

    def _skip(self, kind: str, report_id: int | None = None) -> list[RawSample]:
        self.skipped += 1
        self.skipped_by_kind[kind] += 1
        if report_id is not None:
            self.skipped_by_id[report_id] += 1
        return []

    def _not_pen(self, report: bytes, what: str) -> list[RawSample]:
        """A report whose ID the protocol does not handle: skipped when the descriptor
        declares it (as the kernel's handlers ignore it), else a :class:`ReportError`."""
        if report[0] in self.unused_report_ids:
            return self._skip("unused", report[0])
        raise ReportError(f"unknown {what} report ID {report[0]}")

    def describe(self) -> dict[str, object]:
        """A JSON-ready summary for ``station devices`` and replay reports."""
        r = self.ranges
        return {
            "parser": self.name,
            "generic": self.generic,
            "is_pen": self.is_pen,
            "kind": self.kind,
            "model": None if self.model is None else self.model.get("name"),
            "max_x": r.x.maximum,
            "max_y": r.y.maximum,
            "max_pressure": None if r.pressure is None else r.pressure.maximum,
            "resolution": [r.x.resolution, r.y.resolution],
            "tilt": r.tilt_x is not None,
            "init_features": [b.hex() for b in self.init_features],
            "warning": self.warning,
        }


class IgnoredInterface(ReportParser):
    """An interface of a known device that carries no pen (touch, pad): every report skipped."""

    def __init__(self, name: str, kind: str, ranges: AxisRanges,
                 model: DeviceModel | None = None, generic: bool = False) -> None:
        super().__init__(ranges, model, [], generic=generic, is_pen=False, kind=kind)
        self.name = name

    def parse(self, report: bytes, time: float) -> list[RawSample]:
        return self._skip(self.kind, report[0] if report else None)
