"""Transports: the only code that touches hardware.

Each moves whole HID reports (:class:`HidTransport`: hidraw, hidapi, pyusb,
recordings, mocks) or evdev events (:class:`EvdevTransport`: python-evdev
nodes, recordings) with timestamps from where they arrived.  Parsing happens
downstream (:mod:`station.drivers.pipeline`).
"""

from station.drivers.transport.base import (
    DeviceGone,
    DeviceSpecError,
    EndOfStream,
    EvdevTransport,
    HidDeviceInfo,
    HidTransport,
    PermissionProblem,
    TimedReport,
    TransportError,
)

__all__ = [
    "DeviceGone",
    "DeviceSpecError",
    "EndOfStream",
    "EvdevTransport",
    "HidDeviceInfo",
    "HidTransport",
    "PermissionProblem",
    "TimedReport",
    "TransportError",
]
