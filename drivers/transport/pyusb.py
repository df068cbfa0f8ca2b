"""pyusb transport: a HID interface read straight from its interrupt IN endpoint.

For tablets no kernel driver claims (or when the user asks to take one over).
The kernel driver is detached only when ``detach_kernel_driver=True``; otherwise
an active driver is an error that says to use the hidraw/evdev path instead.
Feature reports go out as HID SET_REPORT control transfers; the report
descriptor comes from GET_DESCRIPTOR(HID report).  Any pyusb backend works,
including :class:`station.drivers.mock.usb.RecordedUsbBackend`.
"""

from __future__ import annotations

import time
from types import ModuleType
from typing import TYPE_CHECKING, TypedDict

from station.drivers.transport.base import (
    DeviceGone,
    DeviceSpecError,
    HidDeviceInfo,
    PermissionProblem,
    TimedReport,
    TransportError,
)

if TYPE_CHECKING:  # pyusb is an optional extra, imported where a transport opens
    import usb.core

USB_CLASS_HID = 3
# HID class requests (HID 1.11 §7.2) and the standard GET_DESCRIPTOR.
REQ_GET_DESCRIPTOR, REQ_SET_REPORT = 0x06, 0x09
HID_REPORT_DESCRIPTOR = 0x22
REPORT_TYPE_FEATURE = 3
RT_STANDARD_IN_INTERFACE = 0x81
RT_STANDARD_IN_DEVICE = 0x80
USB_DT_STRING = 0x03
LANGID_EN_US = 0x0409
RT_CLASS_OUT_INTERFACE = 0x21


def _usb() -> ModuleType:
    try:
        import usb.core
        import usb.util
    except ImportError as exc:  # pragma: no cover - pyusb is a declared extra
        raise TransportError(f"pyusb is not installed ({exc}); pip install pyusb") from None
    return usb


class UsbEntry(TypedDict):
    """A USB device pyusb sees (bus and address as libusb numbers them, when it says)."""

    vid: int
    pid: int
    bus: int | None
    address: int | None


def list_usb(backend: object = None) -> list[UsbEntry]:
    """USB devices pyusb can see (empty when there is no libusb or no device)."""
    usb = _usb()
    try:
        devices = list(usb.core.find(find_all=True, backend=backend) or [])
    except usb.core.NoBackendError:
        return []
    return [{"vid": d.idVendor, "pid": d.idProduct, "bus": getattr(d, "bus", None),
             "address": getattr(d, "address", None)} for d in devices]


class UsbTransport:
    """Interrupt-IN reports of one HID interface of ``vid:pid``.

    Args:
        vid, pid: the device.
        backend: a pyusb backend (None: pyusb's default, libusb).
        interface: bInterfaceNumber of the HID interface (None: the first HID
            interface with an interrupt IN endpoint).
        detach_kernel_driver: detach a kernel driver bound to the interface
            (re-attached on close).
        timeout_ms: default read timeout.
    """

    def __init__(self, vid: int, pid: int, backend: object = None, interface: int | None = None,
                 detach_kernel_driver: bool = False) -> None:
        usb = _usb()
        self._usb = usb
        try:
            dev = usb.core.find(idVendor=vid, idProduct=pid, backend=backend)
        except usb.core.NoBackendError:
            raise TransportError("pyusb found no USB backend (install libusb-1.0)") from None
        if dev is None:
            raise DeviceSpecError(f"no USB device {vid:04x}:{pid:04x}")
        self._dev = dev
        cfg = dev.get_active_configuration() if _configured(dev) else None
        if cfg is None:
            dev.set_configuration()
            cfg = dev.get_active_configuration()
        intf, ep = self._find_endpoint(cfg, interface)
        self._intf = intf
        self._ep = ep
        self._detached = False
        number = intf.bInterfaceNumber
        try:
            active = dev.is_kernel_driver_active(number)
        except (NotImplementedError, usb.core.USBError):
            active = False
        if active:
            if not detach_kernel_driver:
                raise TransportError(
                    f"a kernel driver owns interface {number} of {vid:04x}:{pid:04x}; use the "
                    "hidraw: or evdev: device instead, or ask for ?detach=1 to take it over"
                )
            dev.detach_kernel_driver(number)
            self._detached = True
        try:
            usb.util.claim_interface(dev, number)
        except usb.core.USBError as exc:
            if getattr(exc, "errno", None) == 13:
                raise PermissionProblem(
                    f"no permission for USB {vid:04x}:{pid:04x}; install the station udev rules"
                ) from None
            raise TransportError(f"cannot claim interface {number}: {exc}") from None
        descriptor = self._report_descriptor(number)
        name = _string(dev, "iProduct") or f"usb {vid:04x}:{pid:04x}"
        self.info = HidDeviceInfo(
            name=name, vid=vid, pid=pid, bus=3,
            path=f"usb:{getattr(dev, 'bus', 0)}:{getattr(dev, 'address', 0)}:{number}",
            descriptor=descriptor,
        )
        self.features_sent: list[bytes] = []

    @staticmethod
    def _find_endpoint(cfg: usb.core.Configuration, interface: int | None,
                       ) -> tuple[usb.core.Interface, usb.core.Endpoint]:
        for intf in cfg:
            if intf.bInterfaceClass != USB_CLASS_HID:
                continue
            if interface is not None and intf.bInterfaceNumber != interface:
                continue
            for ep in intf:
                is_in = ep.bEndpointAddress & 0x80
                is_interrupt = (ep.bmAttributes & 0x3) == 3
                if is_in and is_interrupt:
                    return intf, ep
        which = f"interface {interface}" if interface is not None else "any interface"
        raise DeviceSpecError(f"no HID interrupt IN endpoint on {which}")

    def _report_descriptor(self, number: int) -> bytes | None:
        # The HID class descriptor (type 0x21) inside the interface's extra bytes
        # says how long the report descriptor is; ask for 4096 if it is missing.
        length = 4096
        extra = bytes(getattr(self._intf, "extra_descriptors", b"") or b"")
        if len(extra) >= 9 and extra[1] == 0x21:
            length = extra[7] | extra[8] << 8
        try:
            data = self._dev.ctrl_transfer(RT_STANDARD_IN_INTERFACE, REQ_GET_DESCRIPTOR,
                                           HID_REPORT_DESCRIPTOR << 8, number, length)
        except self._usb.core.USBError:
            return None
        return bytes(data)

    def read(self, timeout: float | None = None) -> TimedReport | None:
        ms = 0 if timeout is None else max(1, int(timeout * 1000))
        try:
            data = self._ep.read(self._ep.wMaxPacketSize, ms)
        except self._usb.core.USBTimeoutError:
            return None
        except self._usb.core.USBError as exc:
            if getattr(exc, "errno", None) in (19, 5):  # ENODEV, EIO: unplugged
                raise DeviceGone(f"{self.info.path}: device removed") from None
            raise TransportError(f"{self.info.path}: read failed ({exc})") from None
        return TimedReport(time.monotonic(), bytes(data))

    def send_feature(self, data: bytes) -> None:
        data = bytes(data)
        report_id = data[0] if data else 0
        try:
            self._dev.ctrl_transfer(RT_CLASS_OUT_INTERFACE, REQ_SET_REPORT,
                                    REPORT_TYPE_FEATURE << 8 | report_id,
                                    self._intf.bInterfaceNumber, data)
        except self._usb.core.USBError as exc:
            raise TransportError(f"{self.info.path}: SET_REPORT {data.hex(' ')} failed ({exc})") \
                from None
        self.features_sent.append(data)

    def get_string_descriptor(self, index: int, length: int) -> bytes | None:
        """GET_DESCRIPTOR(string ``index``, US English) as raw bytes; None when the device stalls.

        UC-Logic tablets keep binary parameters in such "strings" (see
        :mod:`station.drivers.uclogic.init`); reading them switches their mode.
        """
        try:
            data = self._dev.ctrl_transfer(RT_STANDARD_IN_DEVICE, REQ_GET_DESCRIPTOR,
                                           USB_DT_STRING << 8 | index, LANGID_EN_US, length)
        except self._usb.core.USBError as exc:
            if getattr(exc, "errno", None) == 32:  # EPIPE: no such descriptor
                return None
            raise TransportError(f"{self.info.path}: string descriptor {index} failed ({exc})") \
                from None
        return bytes(data)

    def write_interrupt(self, endpoint: int, data: bytes) -> None:
        """Write ``data`` to interrupt OUT ``endpoint`` of the device (UGEE v2 set-up)."""
        try:
            sent = self._dev.write(endpoint & 0x7F, bytes(data), 1000)
        except self._usb.core.USBError as exc:
            raise TransportError(f"{self.info.path}: interrupt OUT {endpoint:#04x} failed "
                                 f"({exc})") from None  # fmt: skip
        if sent != len(data):
            raise TransportError(f"{self.info.path}: interrupt OUT sent {sent} of "
                                 f"{len(data)} bytes")

    def close(self) -> None:
        number = self._intf.bInterfaceNumber
        try:
            self._usb.util.release_interface(self._dev, number)
            if self._detached:
                self._dev.attach_kernel_driver(number)
        finally:
            self._usb.util.dispose_resources(self._dev)


def _configured(dev: usb.core.Device) -> bool:
    try:
        dev.get_active_configuration()
    except Exception:  # pyusb raises USBError or NotFound when unconfigured
        return False
    return True


def _string(dev: object, field: str) -> str:
    index = getattr(dev, field, 0)
    if not index:
        return ""
    try:
        return str(_usb().util.get_string(dev, index))
    except Exception:  # strings are cosmetic; a device that refuses them still works
        return ""
