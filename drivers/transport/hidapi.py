"""hidapi transport (``pip install hidapi``): the portable way to a HID device.

hidapi on Linux sits on hidraw (or libusb); it does not give timestamps, so
reports are stamped with ``time.monotonic()`` when ``read`` returns them.
"""

from __future__ import annotations

import time
from types import ModuleType
from typing import TypedDict

from station.drivers.transport.base import (
    DeviceGone,
    DeviceSpecError,
    HidDeviceInfo,
    PermissionProblem,
    TimedReport,
    TransportError,
)

MAX_REPORT = 16384  # the kernel's HID_MAX_BUFFER_SIZE (report ID included)


def _hid() -> ModuleType:
    try:
        import hid
    except ImportError as exc:  # pragma: no cover - hidapi is a declared extra
        raise TransportError(f"hidapi is not installed ({exc}); pip install hidapi") from None
    return hid


class HidapiEntry(TypedDict, total=False):
    """One interface in hidapi's device list (``hid.enumerate``)."""

    path: bytes
    vendor_id: int
    product_id: int
    serial_number: str
    release_number: int
    manufacturer_string: str
    product_string: str
    usage_page: int
    usage: int
    interface_number: int
    bus_type: int  # HID_API_BUS_*: 1 USB, 2 Bluetooth, 3 I2C, 4 SPI


def enumerate_hidapi(vid: int = 0, pid: int = 0) -> list[HidapiEntry]:
    """hidapi's device list (empty when hidapi is missing or sees nothing)."""
    try:
        return list(_hid().enumerate(vid, pid))
    except TransportError:
        return []


class HidapiTransport:
    """One HID interface opened through hidapi, by ``path`` or by ``vid``/``pid``."""

    def __init__(self, vid: int = 0, pid: int = 0, path: bytes | None = None,
                 interface: int | None = None) -> None:
        hid = _hid()
        if path is None:
            matches = [d for d in hid.enumerate(vid, pid)
                       if interface is None or d.get("interface_number") == interface]
            if not matches:
                raise DeviceSpecError(f"no HID device {vid:04x}:{pid:04x} visible to hidapi")
            entry = matches[0]
            path = entry["path"]
        else:
            entry = next((d for d in hid.enumerate() if d.get("path") == path), {})
        self._dev = hid.device()
        try:
            self._dev.open_path(path)
        except OSError as exc:
            raise PermissionProblem(
                f"hidapi cannot open {path!r} ({exc}); check the station udev rules "
                "(docs/drivers.md)"
            ) from None
        try:
            descriptor: bytes | None = bytes(self._dev.get_report_descriptor(MAX_REPORT))
        except (OSError, ValueError, AttributeError):
            descriptor = None
        self.info = HidDeviceInfo(
            name=str(entry.get("product_string") or self._dev.get_product_string() or "hid"),
            vid=int(entry.get("vendor_id", vid)),
            pid=int(entry.get("product_id", pid)),
            bus=_bus_from_hidapi(entry.get("bus_type")),
            path=path.decode("utf-8", "replace") if isinstance(path, bytes) else str(path),
            descriptor=descriptor,
        )

    def read(self, timeout: float | None = None) -> TimedReport | None:
        ms = -1 if timeout is None else max(0, int(timeout * 1000))
        try:
            data = self._dev.read(MAX_REPORT, ms)
        except (OSError, ValueError) as exc:
            raise DeviceGone(f"{self.info.path}: read failed ({exc})") from None
        if not data:
            return None
        return TimedReport(time.monotonic(), bytes(data))

    def send_feature(self, data: bytes) -> None:
        try:
            n = self._dev.send_feature_report(bytes(data))
        except (OSError, ValueError) as exc:
            raise TransportError(f"{self.info.path}: feature report refused ({exc})") from None
        if n < 0:
            raise TransportError(f"{self.info.path}: feature report {bytes(data).hex(' ')} refused")

    def close(self) -> None:
        self._dev.close()


def _bus_from_hidapi(bus_type: int | None) -> int:
    """hidapi's HID_API_BUS_* (1 USB, 2 Bluetooth, 3 I2C, 4 SPI) → Linux BUS_* numbers."""
    return {1: 3, 2: 5, 3: 0x18, 4: 0x1C}.get(int(bus_type or 1), 3)
