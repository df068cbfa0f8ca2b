"""The driver pipeline: transport → parser → normaliser → (transform) → sinks.

One :class:`PenSource` per device turns transport input into raw samples (a
HID report parser or the evdev frame assembler); :class:`PenDriver` feeds
them through a :class:`~station.drivers.normalise.Normaliser` and hands the
pen samples to a sink (the bus, a session log).  :func:`open_device` builds
the source from a device SPEC string (see docs/drivers.md):

``mock:MODEL?script=…&rate=…``, ``mock-hidraw:REC.hid``, ``mock-usb:REC.hid``,
``trace:FILE``, ``evdev:/dev/input/eventN``, ``hidraw:/dev/hidrawN``,
``hidapi:VID:PID``, ``usb:VID:PID``.

:class:`TraceReplay` plays every pen device of a trace through the same
sources, merged in time order; interfaces that are not pens are skipped and listed.

The rooms: :mod:`~station.drivers.pipeline.spec` (SPEC parsing),
:mod:`~station.drivers.pipeline.sources` (pen sources),
:mod:`~station.drivers.pipeline.opening` (from a SPEC to a source),
:mod:`~station.drivers.pipeline.driver` (the driver loop) and
:mod:`~station.drivers.pipeline.replay` (trace replay).
"""

from station.drivers.pipeline.driver import PenDriver, run_paced
from station.drivers.pipeline.opening import OpenedTransport, open_device, open_transport
from station.drivers.pipeline.replay import TraceReplay, iter_trace_samples
from station.drivers.pipeline.sources import (
    BAD_WARNINGS,
    EvdevPenSource,
    HidPenSource,
    PenSource,
    SourceStats,
)
from station.drivers.pipeline.spec import HAPTIC_SCHEMES, SCHEMES, DeviceSpec
from station.drivers.transport.base import EndOfStream, TransportError

__all__ = [
    "BAD_WARNINGS",
    "HAPTIC_SCHEMES",
    "SCHEMES",
    "DeviceSpec",
    "EndOfStream",
    "EvdevPenSource",
    "HidPenSource",
    "OpenedTransport",
    "PenDriver",
    "PenSource",
    "SourceStats",
    "TraceReplay",
    "TransportError",
    "iter_trace_samples",
    "open_device",
    "open_transport",
    "run_paced",
]
