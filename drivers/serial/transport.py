"""The serial transport: the only code that touches a haptic device's port (pyserial).

It moves bytes, nothing else: :meth:`SerialTransport.read` returns what has
arrived (``b""`` when nothing came within the timeout), :meth:`write` sends a
whole frame.  pyserial opens and configures the port; frames are written on its
non-blocking descriptor here, because pyserial's ``write_timeout`` counts the
writer's own scheduling delays: a thread preempted for longer than the timeout
inside ``write()`` gets "Write timeout" although every byte went out, and a
loaded machine then looks like an unplugged device.  Here only a device that
leaves its input buffer full for :data:`WRITE_TIMEOUT` is "gone".  An
unplugged device (read/write errors, the node vanishing) raises
:class:`DeviceGone`; a port that cannot be opened raises :class:`TransportError`
(or :class:`PermissionProblem`).

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
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from station.drivers.transport.base import (
    DeviceGone,
    DeviceSpecError,
    PermissionProblem,
    TransportError,
)

if TYPE_CHECKING:  # pyserial is the optional serial extra, imported where a port opens
    import serial

log = logging.getLogger(__name__)

DEFAULT_BAUD = 921600
"""USB CDC ignores the baud rate; a real UART needs ≥ 500 kbaud for 1 kHz poses and forces."""
SYMLINK_DIR = "/dev"
GROUP = "station"
READ_CHUNK = 4096
MAX_CHUNKS = 256
"""A read takes at most 1 MiB (seconds of poses): a device that floods cannot stall the loop."""
WRITE_TIMEOUT = 0.05
"""Seconds a device may leave its input buffer full before it counts as gone, s."""


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

    def __init__(self, port: str, baudrate: int = DEFAULT_BAUD,
                 serial_factory: Callable[..., serial.Serial] | None = None) -> None:
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
            self._serial = factory(port, baudrate=baudrate, timeout=0, write_timeout=0,
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
        try:
            # pyserial opens it so already; write() relies on it never blocking.
            os.set_blocking(self.fileno(), False)
        except (AttributeError, OSError, ValueError, serial.SerialException) as exc:
            self.close()
            raise TransportError(f"{port}: cannot make the port non-blocking ({exc})") from None
        self.bytes_in = 0
        self.bytes_out = 0

    def fileno(self) -> int:
        return int(self._serial.fileno())

    def read(self, timeout: float | None = 0.0) -> bytes:
        """All the bytes that arrived (waiting up to ``timeout`` s for the first).

        All of them: a loop that was held up must catch up with the device at once, not
        4 KiB a tick behind it (its forces would follow ever older poses).  Raises
        DeviceGone when the device is unplugged.
        """
        try:
            if timeout:
                ready, _, _ = select.select([self._serial.fileno()], [], [], timeout)
                if not ready:
                    return b""
            chunks = [bytes(self._serial.read(READ_CHUNK))]
            while len(chunks[-1]) == READ_CHUNK and len(chunks) < MAX_CHUNKS:
                chunks.append(bytes(self._serial.read(READ_CHUNK)))
            data = b"".join(chunks)
        except (self._error, OSError, ValueError, TypeError) as exc:
            raise DeviceGone(f"{self.port}: {exc}") from None
        self.bytes_in += len(data)
        return data

    def write(self, data: bytes) -> None:
        """Send one frame whole; DeviceGone if the device went away or stopped reading.

        Waits for room only while the port's buffer is full, and judges the
        device by whether it drains that buffer within :data:`WRITE_TIMEOUT`,
        not by the time this thread spent preempted.
        """
        view = memoryview(data)
        deadline: float | None = None
        try:
            fd = self.fileno()
            while view:
                try:
                    n = os.write(fd, view)
                except BlockingIOError:
                    n = 0
                view = view[n:]
                if not view:
                    break
                now = time.monotonic()
                if deadline is None:
                    deadline = now + WRITE_TIMEOUT
                # After a stall of our own the deadline may be past: a zero-timeout select
                # still reports a buffer the device has drained meanwhile.
                _, ready, _ = select.select([], [fd], [], max(0.0, deadline - now))
                if not ready:
                    raise DeviceGone(f"{self.port}: the device stopped reading (its input "
                                     f"buffer stayed full for {WRITE_TIMEOUT * 1000:.0f} ms)")
        except (self._error, OSError, ValueError, TypeError) as exc:
            raise DeviceGone(f"{self.port}: {exc}") from None
        self.bytes_out += len(data)

    def close(self) -> None:
        try:
            self._serial.close()
        except (self._error, OSError):
            pass
