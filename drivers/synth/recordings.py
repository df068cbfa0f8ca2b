"""Synthetic recordings: devices of a hid-recorder file, written through the
station's one hid-recorder writer, and whole strokes on every supported protocol."""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from station.drivers.hid import usages as U
from station.drivers.hid.descriptor import parse_descriptor
from station.drivers.synth.descriptors import (
    encode_report,
    huion_like_descriptor,
    ntrig_like_descriptor,
    pth660_like_descriptor,
    touch_descriptor,
    wacom_protocol_descriptor,
)
from station.drivers.synth.reports import (
    bamboo_pen,
    graphire_report,
    intuos_pen,
    intuos_prox_in,
    intuos_prox_out,
)
from station.drivers.traces.hidrecorder import HidRecorderWriter

# -- hid-recorder text ------------------------------------------------------------------------


@dataclass
class RecordedDevice:
    """One device of a hid-recorder file.

    Attributes:
        name: the ``N:`` line.
        vid, pid: ids for the ``I:`` line; bus: 3 USB, 5 Bluetooth, 0x18 I2C.
        descriptor: the ``R:`` bytes.
        events: (time in seconds, report bytes) in time order.
        phys: the ``P:`` line (may be empty).
    """

    name: str
    vid: int
    pid: int
    descriptor: bytes
    events: list[tuple[float, bytes]] = field(default_factory=list)
    bus: int = 3
    phys: str = ""


def write_hid_recorder(devices: list[RecordedDevice], out: TextIO | str | Path | None = None,
                       *, upper: bool = False, pad: bool = True, start: float = 0.0,
                       comments: bool = True, always_device_lines: bool = False) -> str:
    """Write hid-recorder text; returns it (and writes it to ``out`` when given).

    Variants: ``upper`` hex digits, ``pad=False`` drops zero padding of bytes
    and seconds, ``start`` shifts every timestamp (recordings may start at
    any time), ``comments`` adds ``#`` lines.  Events of all devices are
    merged in time order with a ``D:`` line whenever the device changes
    (always, when more than one device, or ``always_device_lines``).  The text
    comes from the station's one hid-recorder writer
    (:class:`~station.drivers.traces.hidrecorder.HidRecorderWriter`).
    """
    buf = io.StringIO()
    writer = HidRecorderWriter(
        buf, upper=upper, pad=pad, pad_seconds=pad, origin=-start,
        device_lines=len(devices) > 1 or always_device_lines,
        comment="synthetic recording written by station.drivers.synth" if comments else None)
    for dev in devices:
        writer.add_device(dev.name, dev.vid, dev.pid, dev.bus, dev.descriptor, dev.phys,
                          comment=dev.name if comments else None)
    merged = sorted(((t, i, data) for i, dev in enumerate(devices) for t, data in dev.events),
                    key=lambda e: (e[0], e[1]))  # fmt: skip
    for t, i, data in merged:
        writer.write_report(t, data, device=i)
    text = buf.getvalue()
    if isinstance(out, (str, Path)):
        Path(out).write_text(text, encoding="utf-8")
    elif out is not None:
        out.write(text)
    return text


# -- whole synthetic recordings ------------------------------------------------------------


@dataclass(frozen=True)
class SynthDevice:
    """A synthetic device kind: ids, descriptor and report rate."""

    name: str
    vid: int
    pid: int
    bus: int
    descriptor: bytes
    rate_hz: float


def synth_devices() -> dict[str, SynthDevice]:
    """The device kinds :func:`stroke_recording` can write (one per supported protocol)."""
    return {
        "intuos-pro": SynthDevice("Wacom Intuos Pro M Pen", 0x056A, 0x0315, 3,
                                  wacom_protocol_descriptor(9), 200.0),
        "intuos4": SynthDevice("Wacom Intuos4 4x6 Pen", 0x056A, 0x00B8, 3,
                               wacom_protocol_descriptor(9), 190.0),
        "cintiq-22hd": SynthDevice("Wacom Cintiq 22HD Pen", 0x056A, 0x00FA, 3,
                                   wacom_protocol_descriptor(9), 128.0),
        "intuos-s": SynthDevice("Wacom Intuos S Pen", 0x056A, 0x030E, 3,
                                wacom_protocol_descriptor(9), 133.0),
        "bamboo-pen": SynthDevice("Wacom Bamboo Pen", 0x056A, 0x00D4, 3,
                                  wacom_protocol_descriptor(8), 133.0),
        "graphire": SynthDevice("Wacom Graphire", 0x056A, 0x0081, 3,
                                wacom_protocol_descriptor(7), 100.0),
        "graphire-bt": SynthDevice("Wacom Graphire Bluetooth", 0x056A, 0x0081, 5,
                                   wacom_protocol_descriptor(7), 100.0),
        "pth660": SynthDevice("Wacom Intuos Pro M Pen (PTH-660)", 0x056A, 0x0357, 3,
                              pth660_like_descriptor(), 200.0),
        "huion": SynthDevice("Huion-like Tablet Pen", 0x256C, 0x006D, 3,
                             huion_like_descriptor(), 233.0),
        "ntrig": SynthDevice("N-trig-like Pen", 0x1B96, 0x1B05, 0x18,
                             ntrig_like_descriptor(), 83.0),
        "touch": SynthDevice("Synthetic Touch", 0x056A, 0x0357, 3, touch_descriptor(), 100.0),
    }  # fmt: skip


def _times(n: int, rate_hz: float, start: float) -> list[float]:
    """Report times at ``rate_hz`` on USB 1 ms frames: intervals alternate around the period."""
    period_ms = 1000.0 / rate_hz
    lo, hi = math.floor(period_ms), math.ceil(period_ms)
    t, out = start, []
    for i in range(n):
        out.append(round(t, 6))
        t += (lo if i % 2 else hi) / 1000.0 if lo != hi else period_ms / 1000.0
    return out


def stroke_points(n: int) -> list[tuple[float, float, float, float, float]]:
    """A stroke of ``n`` points: (u, v) in [0.2, 0.8], pressure 0 -> 1 -> 0 (sine), tilt in
    [-1, 1] (a fraction of each protocol's tilt range)."""
    out = []
    for i in range(n):
        a = i / max(1, n - 1)
        out.append((0.2 + 0.6 * a, 0.5 + 0.3 * math.sin(2 * math.pi * a),
                    math.sin(math.pi * a), 0.5 * math.cos(math.pi * a), -0.25 + 0.5 * a))
    return out


def stroke_reports(kind: str, n: int = 50, tool_id: int = 0x802,
                   serial: int = 0x1A2B3C4) -> list[bytes]:
    """Reports of one stroke on a device kind of :func:`synth_devices`: proximity in, 3
    hover reports, ``n`` contact reports along :func:`stroke_points`, 2 hover reports,
    proximity out (for generic pens: an in-range-0 report)."""
    pts = stroke_points(n)
    hover = [(0.2, 0.5, 0.0, 0.0, 0.0)] * 3
    after = [(0.8, 0.5, 0.0, 0.0, 0.0)] * 2
    path = hover + pts + after
    if kind in ("intuos-pro", "intuos4", "cintiq-22hd"):
        mx, my = {"intuos-pro": (44704, 27940), "intuos4": (31496, 19685),
                  "cintiq-22hd": (95840, 54260)}[kind]  # fmt: skip
        out = [intuos_prox_in(tool_id, serial)]
        for u, v, p, tx, ty in path:
            out.append(intuos_pen(round(u * mx), round(v * my), round(p * 2047), round(tx * 63),
                                  round(ty * 63), 0 if p else 20))  # fmt: skip
        return [*out, intuos_prox_out()]
    if kind in ("intuos-s", "bamboo-pen"):
        mx, my = (15200, 9500) if kind == "intuos-s" else (14720, 9200)
        length = 10 if kind == "intuos-s" else 9
        out = [bamboo_pen(round(u * mx), round(v * my), round(p * 1023), tip=p > 0.05,
                          raw_distance=31 if p else 20, length=length)
               for u, v, p, _, _ in path]  # fmt: skip
        return [*out, bamboo_pen(0, 0, in_range=False, prox=False, ready=False, length=length)]
    if kind in ("graphire", "graphire-bt"):
        bt = kind == "graphire-bt"
        out = [graphire_report(round(u * 16704), round(v * 12064), round(p * 511), tip=p > 0.05,
                               bluetooth=bt) for u, v, p, _, _ in path]  # fmt: skip
        return [*out, graphire_report(0, 0, prox=False, bluetooth=bt)]
    if kind in ("pth660", "huion", "ntrig"):
        desc = parse_descriptor(synth_devices()[kind].descriptor)
        rid, mx, my, mp, mt = {"pth660": (0x10, 44800, 29600, 8191, 9000),
                               "huion": (0x0A, 50800, 31750, 8191, 60),
                               "ntrig": (0x02, 9600, 7200, 1023, 60)}[kind]  # fmt: skip
        out = []
        for u, v, p, tx, ty in path:
            out.append(encode_report(desc, rid, {
                U.GD_X: round(u * mx), U.GD_Y: round(v * my), U.DG_TIP_PRESSURE: round(p * mp),
                U.DG_TIP_SWITCH: int(p > 0.05), U.DG_IN_RANGE: 1, U.DG_X_TILT: round(tx * mt),
                U.DG_Y_TILT: round(ty * mt), U.DG_TRANSDUCER_SERIAL: serial,
                U.WD_TOOL_TYPE: tool_id,
            }))  # fmt: skip
        out.append(encode_report(desc, rid, {U.GD_X: round(0.8 * mx), U.GD_Y: round(0.5 * my)}))
        return out
    if kind == "touch":
        d = parse_descriptor(touch_descriptor())
        return [encode_report(d, 0x03, {U.DG_TIP_SWITCH: 1, U.GD_X: 100 + i, U.GD_Y: 200,
                                         U.DG_CONTACT_COUNT: 1})
                for i in range(n)]  # fmt: skip
    raise ValueError(f"unknown synthetic device kind {kind!r} (one of {sorted(synth_devices())})")


def stroke_recording(kind: str, n: int = 50, start: float = 0.0, tool_id: int = 0x802,
                     serial: int = 0x1A2B3C4) -> RecordedDevice:
    """One device of a hid-recorder file holding a stroke (see :func:`stroke_reports`),
    timed at the device's report rate with USB-frame jitter, starting at ``start``."""
    dev = synth_devices()[kind]
    reports = stroke_reports(kind, n, tool_id, serial)
    times = _times(len(reports), dev.rate_hz, start)
    return RecordedDevice(dev.name, dev.vid, dev.pid, dev.descriptor,
                          list(zip(times, reports, strict=True)), bus=dev.bus,
                          phys=f"usb-0000:00:14.0-1/input0#{kind}")  # fmt: skip


