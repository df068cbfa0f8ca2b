"""A pyusb backend that presents recorded HID devices through pyusb's own API.

``usb.core.find(idVendor=…, backend=RecordedUsbBackend([...]))`` finds them;
the station's :class:`~station.drivers.transport.pyusb.UsbTransport` then
reads the recorded reports from the interrupt IN endpoint, fetches the report
descriptor with GET_DESCRIPTOR and sends features with SET_REPORT — all through
pyusb's ``core`` layer, so only the wire below pyusb is simulated.

Each device has one configuration, one HID interface (number 0) with one
interrupt IN endpoint (0x81).  ``kernel_driver=True`` simulates usbhid bound to
it (``detach_kernel_driver`` clears it, and the log records it).
"""

from __future__ import annotations

import array
import errno
import logging
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from types import SimpleNamespace

import usb.backend
import usb.core
from station.drivers.transport.base import TimedReport

log = logging.getLogger(__name__)

HID_INTERFACE = 0
IN_ENDPOINT = 0x81


@dataclass
class RecordedUsbDevice:
    """One simulated USB HID device.

    Attributes:
        vid, pid: USB ids.
        name: product string.
        descriptor: HID report descriptor served by GET_DESCRIPTOR(0x22).
        reports: input reports in time order.
        speed: pacing (1.0 real time, None = as fast as read).
        kernel_driver: usbhid is bound to the interface.
        max_packet: wMaxPacketSize of the IN endpoint.
    """

    vid: int
    pid: int
    name: str
    descriptor: bytes
    reports: Iterable[TimedReport]
    speed: float | None = None
    kernel_driver: bool = False
    max_packet: int = 64
    bus: int = 1
    address: int = 7
    features: list[bytes] = field(default_factory=list)
    log: list[str] = field(default_factory=list)
    # Vendor behaviour (UC-Logic): raw string descriptors by index (a stall for any other
    # index above 2), an interrupt OUT endpoint, and hooks the device reacts with.
    strings: dict[int, bytes] = field(default_factory=dict)
    out_endpoint: int | None = None
    on_string: Callable[[int], None] | None = None  # after a string descriptor was read
    on_out: Callable[[int, bytes], None] | None = None  # after an interrupt OUT transfer
    _iter: Iterator[TimedReport] | None = None
    _origin: tuple[float, float] | None = None
    _pending: TimedReport | None = None
    _gone: bool = False

    def next_report(self, timeout_s: float) -> TimedReport | None:
        """The next report once it is due; None if not due within ``timeout_s``."""
        if self._iter is None:
            self._iter = iter(self.reports)
        if self._pending is None:
            try:
                self._pending = next(self._iter)
            except StopIteration:
                self._gone = True
                return None
        report = self._pending
        if self.speed is not None:
            now = time.monotonic()
            if self._origin is None:
                self._origin = (now, report.time)
            due = self._origin[0] + (report.time - self._origin[1]) / self.speed
            if due - now > timeout_s:
                time.sleep(max(0.0, timeout_s))
                return None
            if due > now:
                time.sleep(due - now)
        self._pending = None
        return report


def _hid_class_descriptor(report_len: int) -> bytes:
    # HID descriptor (HID 1.11 §6.2.1): bcdHID 1.11, one report descriptor of report_len bytes.
    return bytes([9, 0x21, 0x11, 0x01, 0, 1, 0x22, report_len & 0xFF, report_len >> 8])


class RecordedUsbBackend(usb.backend.IBackend):
    """A pyusb backend serving :class:`RecordedUsbDevice` objects."""

    def __init__(self, devices: Iterable[RecordedUsbDevice]) -> None:
        self.devices = list(devices)
        self.configured: dict[int, int] = {}

    # -- enumeration and descriptors ---------------------------------------
    def enumerate_devices(self) -> Iterator[RecordedUsbDevice]:
        return iter([d for d in self.devices if not d._gone])

    def get_parent(self, dev: RecordedUsbDevice) -> None:
        return None

    def get_device_descriptor(self, dev: RecordedUsbDevice) -> SimpleNamespace:
        return SimpleNamespace(
            bLength=18, bDescriptorType=1, bcdUSB=0x0200, bDeviceClass=0, bDeviceSubClass=0,
            bDeviceProtocol=0, bMaxPacketSize0=64, idVendor=dev.vid, idProduct=dev.pid,
            bcdDevice=0x0100, iManufacturer=1, iProduct=2, iSerialNumber=0,
            bNumConfigurations=1, address=dev.address, bus=dev.bus, port_number=1,
            port_numbers=(1,), speed=2,
        )

    def get_configuration_descriptor(self, dev: RecordedUsbDevice, config: int) -> SimpleNamespace:
        if config != 0:
            raise IndexError("one configuration")
        return SimpleNamespace(bLength=9, bDescriptorType=2, wTotalLength=34, bNumInterfaces=1,
                               bConfigurationValue=1, iConfiguration=0, bmAttributes=0x80,
                               bMaxPower=50, extra_descriptors=[])

    def get_interface_descriptor(self, dev: RecordedUsbDevice, intf: int, alt: int,
                                 config: int) -> SimpleNamespace:
        if intf != 0 or alt != 0 or config != 0:
            raise IndexError("one interface, one alternate setting")
        return SimpleNamespace(bLength=9, bDescriptorType=4, bInterfaceNumber=HID_INTERFACE,
                               bAlternateSetting=0,
                               bNumEndpoints=1 if dev.out_endpoint is None else 2,
                               bInterfaceClass=3,
                               bInterfaceSubClass=0, bInterfaceProtocol=0, iInterface=0,
                               extra_descriptors=list(_hid_class_descriptor(len(dev.descriptor))))

    def get_endpoint_descriptor(self, dev: RecordedUsbDevice, ep: int, intf: int, alt: int,
                                config: int) -> SimpleNamespace:
        if ep == 1 and dev.out_endpoint is not None and intf == 0 and alt == 0 and config == 0:
            return SimpleNamespace(bLength=7, bDescriptorType=5,
                                   bEndpointAddress=dev.out_endpoint & 0x7F, bmAttributes=0x03,
                                   wMaxPacketSize=dev.max_packet, bInterval=1, bRefresh=0,
                                   bSynchAddress=0, extra_descriptors=[])  # fmt: skip
        if ep != 0 or intf != 0 or alt != 0 or config != 0:
            raise IndexError("one endpoint")
        return SimpleNamespace(bLength=7, bDescriptorType=5, bEndpointAddress=IN_ENDPOINT,
                               bmAttributes=0x03, wMaxPacketSize=dev.max_packet, bInterval=1,
                               bRefresh=0, bSynchAddress=0, extra_descriptors=[])

    # -- handles --------------------------------------------------------------
    def open_device(self, dev: RecordedUsbDevice) -> RecordedUsbDevice:
        if dev._gone:
            raise usb.core.USBError("No such device", errno=errno.ENODEV)
        dev.log.append("open")
        return dev

    def close_device(self, handle: RecordedUsbDevice) -> None:
        handle.log.append("close")

    def set_configuration(self, handle: RecordedUsbDevice, config_value: int) -> None:
        self.configured[id(handle)] = config_value

    def get_configuration(self, handle: RecordedUsbDevice) -> int:
        return self.configured.get(id(handle), 1)

    def set_interface_altsetting(self, handle: RecordedUsbDevice, intf: int, alt: int) -> None:
        pass

    def claim_interface(self, handle: RecordedUsbDevice, intf: int) -> None:
        if handle.kernel_driver:
            raise usb.core.USBError("Resource busy", errno=errno.EBUSY)
        handle.log.append(f"claim {intf}")

    def release_interface(self, handle: RecordedUsbDevice, intf: int) -> None:
        handle.log.append(f"release {intf}")

    def is_kernel_driver_active(self, handle: RecordedUsbDevice, intf: int) -> bool:
        return handle.kernel_driver

    def detach_kernel_driver(self, handle: RecordedUsbDevice, intf: int) -> None:
        handle.kernel_driver = False
        handle.log.append(f"detach {intf}")

    def attach_kernel_driver(self, handle: RecordedUsbDevice, intf: int) -> None:
        handle.kernel_driver = True
        handle.log.append(f"attach {intf}")

    # -- transfers -------------------------------------------------------------
    def intr_read(self, handle: RecordedUsbDevice, ep: int, intf: int, buff: array.array[int],
                  timeout: int) -> int:
        if ep != IN_ENDPOINT:
            raise usb.core.USBError("Invalid endpoint", errno=errno.EINVAL)
        report = handle.next_report((timeout or 1000) / 1000.0)
        if report is None:
            if handle._gone:
                raise usb.core.USBError("No such device (it may have been disconnected)",
                                        errno=errno.ENODEV)
            raise usb.core.USBTimeoutError("Operation timed out", errno=errno.ETIMEDOUT)
        n = min(len(report.data), len(buff))
        buff[:n] = type(buff)(buff.typecode, report.data[:n])
        return n

    def intr_write(self, handle: RecordedUsbDevice, ep: int, intf: int, data: array.array[int],
                   timeout: int) -> int:
        if handle.out_endpoint is None or ep != handle.out_endpoint & 0x7F:
            raise usb.core.USBError("Invalid endpoint", errno=errno.EINVAL)
        sent = bytes(data)
        handle.log.append(f"out {ep:#04x} {sent.hex(' ')}")
        if handle.on_out is not None:
            handle.on_out(ep, sent)
        return len(sent)

    def ctrl_transfer(self, handle: RecordedUsbDevice, bmRequestType: int, bRequest: int,
                      wValue: int, wIndex: int, data: array.array[int], timeout: int) -> int:
        if bmRequestType & 0x80 and bRequest == 0x06:  # GET_DESCRIPTOR
            kind, index = wValue >> 8, wValue & 0xFF
            if kind == 0x22:
                payload = handle.descriptor
            elif kind == 0x03 and index in handle.strings:
                payload = handle.strings[index]
                handle.log.append(f"string {index}")
                if handle.on_string is not None:
                    handle.on_string(index)
            elif kind == 0x03 and index <= 2:
                text = {1: "Station mock", 2: handle.name}.get(index, "")
                body = b"\x09\x04" if index == 0 else text.encode("utf-16-le")
                payload = bytes([2 + len(body), 3]) + body
            else:
                raise usb.core.USBError("Pipe error", errno=errno.EPIPE)
            n = min(len(payload), len(data))
            data[:n] = type(data)(data.typecode, payload[:n])
            return n
        if bmRequestType == 0x21 and bRequest == 0x09:  # HID SET_REPORT
            sent = bytes(data)
            handle.features.append(sent)
            handle.log.append(f"set_report {wValue:#06x} {sent.hex(' ')}")
            return len(sent)
        raise usb.core.USBError("Pipe error", errno=errno.EPIPE)
