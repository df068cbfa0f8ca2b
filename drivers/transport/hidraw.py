"""hidraw transport: ``/dev/hidrawN`` read with ``os.read``, ioctls for the rest.

:class:`HidrawTransport` does the reading (select + ``os.read``, one report
per read as hidraw guarantees) over a :class:`HidrawNode`.  The node is either
the real character device (:class:`OsHidrawNode`, ioctls HIDIOCGRDESC,
HIDIOCGRAWINFO, HIDIOCGRAWNAME, HIDIOCSFEATURE) or a mock serving a recording
over a SOCK_SEQPACKET socket (:mod:`station.drivers.mock.hidraw`), so the same
read path runs in tests.
"""

from __future__ import annotations

import array
import errno
import fcntl
import os
import select
import stat
import struct
import time
from pathlib import Path
from typing import Protocol, TypedDict

from station.drivers.transport.base import (
    DeviceGone,
    EndOfStream,
    HidDeviceInfo,
    PermissionProblem,
    TimedReport,
    TransportError,
    WrongNodeKind,
)

_IOC_WRITE, _IOC_READ = 1, 2
HID_MAX_DESCRIPTOR_SIZE = 4096
MAX_REPORT = 16384  # the kernel's HID_MAX_BUFFER_SIZE (report ID included)


def _ioc(direction: int, nr: int, size: int) -> int:
    return (direction << 30) | (size << 16) | (ord("H") << 8) | nr


HIDIOCGRDESCSIZE = _ioc(_IOC_READ, 0x01, 4)
HIDIOCGRDESC = _ioc(_IOC_READ, 0x02, 4 + HID_MAX_DESCRIPTOR_SIZE)
HIDIOCGRAWINFO = _ioc(_IOC_READ, 0x03, 8)


def HIDIOCGRAWNAME(length: int) -> int:
    return _ioc(_IOC_READ, 0x04, length)


def HIDIOCGRAWPHYS(length: int) -> int:
    return _ioc(_IOC_READ, 0x05, length)


def HIDIOCSFEATURE(length: int) -> int:
    return _ioc(_IOC_READ | _IOC_WRITE, 0x06, length)


class HidrawNode(Protocol):
    """What the transport needs from a hidraw node."""

    path: str

    def fileno(self) -> int: ...

    def descriptor(self) -> bytes: ...

    def raw_info(self) -> tuple[int, int, int]:
        """(bus, vid, pid)."""
        ...

    def name(self) -> str: ...

    def phys(self) -> str: ...

    def set_feature(self, data: bytes) -> None: ...

    def close(self) -> None: ...


def permission_hint(path: str) -> str:
    return (
        f"no permission to open {path}: install the station's udev rules "
        "(station/udev, see docs/drivers.md) so the seat user gets access via uaccess, "
        "or add yourself to the 'station' group and log in again"
    )


def check_hidraw_node(path: str, st: os.stat_result) -> None:
    """Refuse (one line) a path that is not a hidraw character device: a file, a FIFO,
    /dev/null or an evdev node would answer the hidraw ioctls with ENOTTY (or
    nothing) deep inside the driver."""
    if not stat.S_ISCHR(st.st_mode):
        raise WrongNodeKind(f"{path} is not a character device: hidraw: needs a "
                            "/dev/hidrawN node")
    sysfs = Path(f"/sys/dev/char/{os.major(st.st_rdev)}:{os.minor(st.st_rdev)}/subsystem")
    try:
        subsystem = os.path.basename(os.readlink(sysfs))
    except OSError:
        return  # no sysfs here (a sandbox): the ioctls below say it instead
    if subsystem != "hidraw":
        raise WrongNodeKind(f"{path} is a {subsystem} device, not hidraw: hidraw: needs a "
                            "/dev/hidrawN node (evdev: takes /dev/input/eventN)")


class OsHidrawNode:
    """The kernel's hidraw character device."""

    def __init__(self, path: str) -> None:
        self.path = path
        try:
            self._fd = os.open(path, os.O_RDWR | os.O_NONBLOCK | os.O_CLOEXEC)
        except PermissionError:
            raise PermissionProblem(permission_hint(path)) from None
        except FileNotFoundError:
            raise TransportError(f"{path}: no such hidraw node (unplugged?)") from None
        except OSError as exc:
            raise TransportError(f"{path}: cannot open ({exc.strerror})") from None
        try:
            check_hidraw_node(path, os.fstat(self._fd))
        except BaseException:
            os.close(self._fd)
            raise

    def fileno(self) -> int:
        return self._fd

    def descriptor(self) -> bytes:
        size = array.array("i", [0])
        fcntl.ioctl(self._fd, HIDIOCGRDESCSIZE, size, True)
        buf = bytearray(struct.pack("I", size[0]) + bytes(HID_MAX_DESCRIPTOR_SIZE))
        fcntl.ioctl(self._fd, HIDIOCGRDESC, buf, True)
        return bytes(buf[4 : 4 + size[0]])

    def raw_info(self) -> tuple[int, int, int]:
        buf = bytearray(8)
        try:
            fcntl.ioctl(self._fd, HIDIOCGRAWINFO, buf, True)
        except OSError as exc:
            if exc.errno in (errno.ENOTTY, errno.EINVAL):
                raise WrongNodeKind(f"{self.path} is not a hidraw node (it does not answer "
                                    "HIDIOCGRAWINFO)") from None
            raise
        bus, vid, pid = struct.unpack("IHH", buf)
        return bus, vid, pid

    def _string(self, request: int) -> str:
        buf = bytearray(256)
        try:
            fcntl.ioctl(self._fd, request, buf, True)
        except OSError:
            return ""
        return buf.split(b"\0", 1)[0].decode("utf-8", "replace")

    def name(self) -> str:
        return self._string(HIDIOCGRAWNAME(256))

    def phys(self) -> str:
        return self._string(HIDIOCGRAWPHYS(256))

    def set_feature(self, data: bytes) -> None:
        buf = bytearray(data)
        fcntl.ioctl(self._fd, HIDIOCSFEATURE(len(buf)), buf, True)

    def close(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


class HidrawTransport:
    """Reads reports from a hidraw node; timestamps are ``time.monotonic()`` at read.

    ``clock`` can be swapped for the node's own clock (a mock serving a
    recording stamps reports with their recorded times).
    """

    def __init__(self, node: HidrawNode) -> None:
        self.node = node
        bus, vid, pid = node.raw_info()
        self.info = HidDeviceInfo(
            name=node.name() or f"hidraw {vid:04x}:{pid:04x}",
            vid=vid,
            pid=pid,
            bus=bus,
            path=node.path,
            descriptor=node.descriptor(),
            phys=node.phys(),
        )
        self.features_sent: list[bytes] = []

    def read(self, timeout: float | None = None) -> TimedReport | None:
        fd = self.node.fileno()
        if fd < 0:
            raise DeviceGone(f"{self.node.path}: closed")
        ready, _, _ = select.select([fd], [], [], timeout)
        if not ready:
            return None
        try:
            data = os.read(fd, MAX_REPORT)
        except BlockingIOError:
            return None
        except OSError as exc:
            if exc.errno in (errno.ENODEV, errno.EIO, errno.ECONNRESET):
                raise DeviceGone(f"{self.node.path}: device removed") from None
            raise TransportError(f"{self.node.path}: read failed ({exc.strerror})") from None
        now = time.monotonic()
        if not data:
            if getattr(self.node, "finite", False):
                raise EndOfStream(f"{self.node.path}: end of recording")
            raise DeviceGone(f"{self.node.path}: device removed")
        stamp = getattr(self.node, "stamp", None)
        return TimedReport(stamp(data, now) if stamp else now, data)

    def now(self) -> float:
        """The clock the report timestamps use (a mock's recording clock, else monotonic)."""
        clock = getattr(self.node, "now", None)
        return float(clock()) if clock is not None else time.monotonic()

    def send_feature(self, data: bytes) -> None:
        try:
            self.node.set_feature(bytes(data))
        except OSError as exc:
            raise TransportError(
                f"{self.node.path}: feature report {bytes(data).hex(' ')} refused ({exc.strerror})"
            ) from None
        self.features_sent.append(bytes(data))

    def close(self) -> None:
        self.node.close()


class HidrawEntry(TypedDict):
    """One hidraw node as sysfs shows it (ids 0 when sysfs does not say)."""

    path: str
    vid: int
    pid: int
    bus: int
    name: str
    phys: str  # the physical path, ``usb-0000:00:14.0-2/input1`` ("" when sysfs does not say)
    readable: bool  # we may open it for reading and writing
    exists: bool  # the /dev node is there


def list_hidraw(sysfs: str = "/sys/class/hidraw") -> list[HidrawEntry]:
    """hidraw nodes from sysfs: path, vid, pid, bus, name, physical path (its
    ``/inputN`` tail is the USB interface: the HID device's uevent carries HID_PHYS, as
    hid-core's ``hid_uevent`` writes it), and whether we may open it."""
    out: list[HidrawEntry] = []
    root = Path(sysfs)
    if not root.is_dir():
        return out
    for entry in sorted(root.iterdir()):
        uevent = entry / "device" / "uevent"
        fields: dict[str, str] = {}
        try:
            for line in uevent.read_text().splitlines():
                key, _, value = line.partition("=")
                fields[key] = value
        except OSError:
            continue
        bus = vid = pid = 0
        hid_id = fields.get("HID_ID", "")
        parts = hid_id.split(":")
        if len(parts) == 3:
            try:
                bus, vid, pid = (int(p, 16) for p in parts)
            except ValueError:
                pass
        node = f"/dev/{entry.name}"
        out.append({
            "path": node,
            "vid": vid,
            "pid": pid,
            "bus": bus,
            "name": fields.get("HID_NAME", ""),
            "phys": fields.get("HID_PHYS", ""),
            "readable": os.access(node, os.R_OK | os.W_OK),
            "exists": os.path.exists(node),
        })
    return out
