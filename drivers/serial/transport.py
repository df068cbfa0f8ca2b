"""The serial transport: the only code that touches a haptic device's port (pyserial).

It moves bytes, nothing else: :meth:`SerialTransport.read` returns what has
arrived (``b""`` when nothing came within the timeout), :meth:`write` sends a
whole frame.  An unplugged device (read/write errors, the node vanishing)
raises :class:`DeviceGone`; a port that cannot be opened raises
:class:`TransportError` (or :class:`PermissionProblem`).

Ports are named by path (``/dev/ttyACM0``) or by USB identity
(``usb:VID:PID[:SERIAL]``): the udev symlink ``/dev/station-haptic-…`` that
``station udev --haptic VID:PID[:SERIAL]`` generates when it exists, else the
port pyserial's enumeration reports with those ids.
"""

from __future__ import annotations

import errno
import logging
import os
import re
import select
from dataclasses import dataclass
from typing import Any

from station.drivers.transport.base import (
    DeviceGone,
    DeviceSpecError,
    PermissionProblem,
    TransportError,
)

log = logging.getLogger(__name__)

DEFAULT_BAUD = 921600
"""USB CDC ignores the baud rate; a real UART needs ≥ 500 kbaud for 1 kHz poses and forces."""
SYMLINK_DIR = "/dev"
GROUP = "station"


@dataclass(frozen=True)
class UsbSerialId:
    """A serial device named by its USB identity."""

    vid: int
    pid: int
    serial: str | None = None

    @classmethod
    def parse(cls, text: str, where: str = "--device") -> UsbSerialId:
        m = re.fullmatch(r"([0-9a-fA-F]{1,4}):([0-9a-fA-F]{1,4})(?::([A-Za-z0-9._-]{1,64}))?",
                         text)
        if not m:
            raise DeviceSpecError(f"{text!r} is not VID:PID[:SERIAL] (hex ids, e.g. "
                                  "2341:8036:A1B2)", where)
        return cls(int(m.group(1), 16), int(m.group(2), 16), m.group(3))

    @property
    def symlink(self) -> str:
        """The name the generated udev rule gives the port under /dev."""
        tail = f"-{self.serial}" if self.serial else ""
        return f"station-haptic-{self.vid:04x}-{self.pid:04x}{tail}"

    def udev_rule(self) -> str:
        """A udev rule giving this device a stable symlink, the seat user and the station group.

        Never world-accessible (0660).  Without a serial number every device
        with these ids gets the same link (the last one plugged in wins).
        """
        match = (f'SUBSYSTEM=="tty", ATTRS{{idVendor}}=="{self.vid:04x}", '
                 f'ATTRS{{idProduct}}=="{self.pid:04x}"')
        if self.serial:
            match += f', ATTRS{{serial}}=="{self.serial}"'
        return (f"# painting station haptic device {self.vid:04x}:{self.pid:04x}"
                f"{' serial ' + self.serial if self.serial else ''}\n"
                f'{match}, SYMLINK+="{self.symlink}", TAG+="uaccess", GROUP="{GROUP}", '
                f'MODE="0660"\n')


def find_usb_port(ident: UsbSerialId) -> str:
    """The port of a USB serial device: its udev symlink, else pyserial's enumeration."""
    link = os.path.join(SYMLINK_DIR, ident.symlink)
    if os.path.exists(link):
        return link
    from serial.tools import list_ports

    found = [p.device for p in list_ports.comports()
             if p.vid == ident.vid and p.pid == ident.pid
             and (ident.serial is None or p.serial_number == ident.serial)]
    if not found:
        raise TransportError(f"no serial device {ident.vid:04x}:{ident.pid:04x}"
                             f"{':' + ident.serial if ident.serial else ''} is plugged in "
                             f"(and no {link})")
    if len(found) > 1:
        raise DeviceSpecError(f"{len(found)} serial devices {ident.vid:04x}:{ident.pid:04x} "
                              f"({', '.join(found)}): add the serial number", "--device")
    return found[0]


class SerialTransport:
    """A serial port opened through pyserial, non-blocking; see the module docstring."""

    def __init__(self, port: str, baudrate: int = DEFAULT_BAUD, serial_factory: Any = None) -> None:
        try:
            import serial  # the optional "serial" extra
        except ImportError:
            raise TransportError("serial haptic devices need pyserial: "
                                 "pip install 'painting-station[serial]'") from None

        self.port = port
        self._error = serial.SerialException
        factory = serial_factory or serial.Serial
        try:
            # exclusive: a second driver on the same device fails instead of stealing frames.
            self._serial = factory(port, baudrate=baudrate, timeout=0, write_timeout=0.05,
                                   exclusive=True)
        except serial.SerialException as exc:
            err = getattr(exc, "errno", None)
            if err in (errno.EACCES, errno.EPERM):
                raise PermissionProblem(f"{port}: permission denied; install the udev rule "
                                        "(station udev --haptic VID:PID) or join the "
                                        f"'{GROUP}' group") from None
            raise TransportError(f"{port}: cannot open ({exc})") from None
        try:
            # FTDI-style adapters buffer 16 ms by default: far too long for a 1 kHz loop.
            self._serial.set_low_latency_mode(True)
        except (AttributeError, OSError, ValueError, serial.SerialException):
            pass  # a pty or a CDC device has no latency timer
        self.bytes_in = 0
        self.bytes_out = 0

    def fileno(self) -> int:
        return int(self._serial.fileno())

    def read(self, timeout: float | None = 0.0) -> bytes:
        """Bytes that arrived (waiting up to ``timeout`` s for the first).

        Raises DeviceGone when the device is unplugged.
        """
        try:
            if timeout:
                ready, _, _ = select.select([self._serial.fileno()], [], [], timeout)
                if not ready:
                    return b""
            data = bytes(self._serial.read(4096))
        except (self._error, OSError, ValueError, TypeError) as exc:
            raise DeviceGone(f"{self.port}: {exc}") from None
        self.bytes_in += len(data)
        return data

    def write(self, data: bytes) -> None:
        """Send one frame whole; DeviceGone if the device went away or stopped reading."""
        try:
            n = self._serial.write(data)
        except (self._error, OSError, ValueError, TypeError) as exc:
            raise DeviceGone(f"{self.port}: {exc}") from None
        self.bytes_out += int(n or 0)

    def close(self) -> None:
        try:
            self._serial.close()
        except (self._error, OSError):
            pass
