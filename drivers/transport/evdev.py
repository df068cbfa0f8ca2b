"""evdev transport (python-evdev): a live ``/dev/input/event*`` node.

Events keep the kernel's timestamps.  The node's current state (EVIOCGABS
values and EVIOCGKEY keys) is offered for SYN_DROPPED resyncs; an exclusive
grab (EVIOCGRAB) is optional.  Unplugging gives ENODEV → :class:`DeviceGone`.
"""

from __future__ import annotations

import errno
import os
import select
import time
from collections.abc import Callable, Collection, Iterable, Mapping
from types import ModuleType
from typing import Any, Protocol, TypedDict

from station.drivers.evdev import codes as c
from station.drivers.evdev.frames import AbsInfo, EvdevCaps, EvdevState, InputEvent
from station.drivers.transport.base import (
    DeviceGone,
    EndOfStream,
    PermissionProblem,
    TransportError,
    WrongNodeKind,
)


class EvdevAbsInfo(Protocol):
    """One axis's limits and value (python-evdev's ``AbsInfo``)."""

    @property
    def value(self) -> int: ...
    @property
    def min(self) -> int: ...
    @property
    def max(self) -> int: ...
    @property
    def fuzz(self) -> int: ...
    @property
    def flat(self) -> int: ...
    @property
    def resolution(self) -> int: ...


class EvdevEvent(Protocol):
    """One event as python-evdev reads it (``InputEvent``)."""

    @property
    def type(self) -> int: ...
    @property
    def code(self) -> int: ...
    @property
    def value(self) -> int: ...
    def timestamp(self) -> float: ...


class EvdevDeviceInfo(Protocol):
    """The ids of a node (python-evdev's ``DeviceInfo``)."""

    @property
    def bustype(self) -> int: ...
    @property
    def vendor(self) -> int: ...
    @property
    def product(self) -> int: ...
    @property
    def version(self) -> int: ...


class EvdevNode(Protocol):
    """What the transport uses of an open node: python-evdev's ``InputDevice``, or
    :class:`station.drivers.mock.evdev.MockEvdevNode` serving a recording."""

    @property
    def name(self) -> str: ...
    @property
    def path(self) -> str: ...
    @property
    def info(self) -> EvdevDeviceInfo: ...
    @property
    def fd(self) -> int: ...
    # values: key codes, or (code, AbsInfo) pairs for EV_ABS
    def capabilities(self, absinfo: bool = True) -> Mapping[int, list[Any]]: ...
    def absinfo(self, code: int) -> EvdevAbsInfo: ...
    def active_keys(self) -> list[int]: ...
    def read(self) -> Iterable[EvdevEvent]: ...
    def grab(self) -> None: ...
    def ungrab(self) -> None: ...
    def close(self) -> None: ...


def _evdev() -> ModuleType:
    try:
        import evdev
    except ImportError as exc:  # pragma: no cover - declared extra on Linux
        raise TransportError(f"python-evdev is not installed ({exc}); pip install evdev-binary") \
            from None
    return evdev


def caps_from_device(dev: EvdevNode) -> EvdevCaps:
    """EvdevCaps from a python-evdev ``InputDevice``."""
    caps = dev.capabilities(absinfo=True)
    absinfo: dict[int, AbsInfo] = {}
    for code, info in caps.get(c.EV_ABS, []):
        absinfo[int(code)] = AbsInfo(info.min, info.max, info.fuzz, info.flat, info.resolution,
                                     info.value)
    keys = frozenset(int(k) for k in caps.get(c.EV_KEY, []))
    msc = frozenset(int(k) for k in caps.get(c.EV_MSC, []))
    return EvdevCaps(name=str(dev.name), absinfo=absinfo, keys=keys, vid=dev.info.vendor,
                     pid=dev.info.product, bus=dev.info.bustype, version=dev.info.version,
                     msc=msc, path=str(dev.path))


class _LiveState:
    """EvdevState read from the node (EVIOCGABS / EVIOCGKEY)."""

    def __init__(self, dev: EvdevNode, codes: Collection[int]) -> None:
        self._dev = dev
        self._codes = list(codes)

    def abs_values(self) -> Mapping[int, int]:
        return {code: int(self._dev.absinfo(code).value) for code in self._codes}

    def active_keys(self) -> Collection[int]:
        return [int(k) for k in self._dev.active_keys()]


def open_error(path: str, exc: OSError) -> TransportError:
    if isinstance(exc, PermissionError):
        return PermissionProblem(
            f"no permission to open {path}: install the station's udev rules (uaccess for the "
            "seat user) or join the 'input'/'station' group; see docs/drivers.md")
    if exc.errno in (errno.ENOENT, errno.ENODEV):
        return DeviceGone(f"{path}: no such device")
    if exc.errno in (errno.ENOTTY, errno.EINVAL):  # a file, /dev/null, a hidraw node …
        return WrongNodeKind(f"{path} is not an evdev node (it does not answer the evdev "
                             "ioctls): evdev: needs /dev/input/eventN (hidraw: takes "
                             "/dev/hidrawN)")
    return TransportError(f"{path}: cannot open ({exc.strerror})")


class EvdevNodeTransport:
    """Reads one evdev node; ``grab=True`` takes it exclusively (no cursor movement).

    ``opener`` makes the device object from the path: python-evdev's
    ``InputDevice`` by default, :class:`station.drivers.mock.evdev.MockEvdevNode`
    (same interface, serving a recording) for ``mock-evdev:`` devices.
    """

    def __init__(self, path: str, grab: bool = False,
                 opener: Callable[[str], EvdevNode] | None = None) -> None:
        try:
            self._dev = (opener or _evdev().InputDevice)(path)
        except OSError as exc:
            raise open_error(path, exc) from None
        self.caps = caps_from_device(self._dev)
        self.grabbed = False
        if grab:
            try:
                self._dev.grab()
                self.grabbed = True
            except OSError as exc:
                raise TransportError(f"{path}: cannot grab ({exc.strerror}); another program "
                                     "holds it exclusively") from None

    def read(self, timeout: float | None = None) -> list[InputEvent]:
        try:
            ready, _, _ = select.select([self._dev.fd], [], [], timeout)
            if not ready:
                return []
            return [InputEvent(ev.timestamp(), ev.type, ev.code, ev.value)
                    for ev in self._dev.read()]
        except BlockingIOError:
            return []
        except OSError as exc:
            if getattr(self._dev, "finite", False) and exc.errno == errno.ENODEV:
                raise EndOfStream(f"{self.caps.path}: end of recording") from None
            if exc.errno in (errno.ENODEV, errno.EBADF, errno.EIO):
                raise DeviceGone(f"{self.caps.path}: device removed") from None
            raise TransportError(f"{self.caps.path}: read failed ({exc.strerror})") from None

    def state(self) -> EvdevState:
        return _LiveState(self._dev, self.caps.absinfo.keys())

    def now(self) -> float:
        clock = getattr(self._dev, "now", None)
        if clock is not None:
            return float(clock())
        return time.time()  # python-evdev timestamps are CLOCK_REALTIME by default

    def close(self) -> None:
        try:
            if self.grabbed:
                self._dev.ungrab()
        except OSError:
            pass
        self._dev.close()


class EvdevEntry(TypedDict, total=False):
    """An event node :func:`list_evdev` found: ``caps`` when it opened, ``error`` when not."""

    path: str
    caps: EvdevCaps
    error: str


def list_evdev(root: str = "/dev/input",
               opener: Callable[[str], EvdevNode] | None = None) -> list[EvdevEntry]:
    """Every event node: its capabilities when readable, the permission problem otherwise."""
    out: list[EvdevEntry] = []
    if not os.path.isdir(root):
        return out
    open_node = opener or _evdev().InputDevice

    def number(name: str) -> int:
        digits = name.removeprefix("event")
        return int(digits) if digits.isdigit() else 1 << 30

    names = sorted((n for n in os.listdir(root) if n.startswith("event")), key=number)
    for path in (os.path.join(root, n) for n in names):
        try:
            dev = open_node(path)
        except OSError as exc:
            out.append({"path": path, "error": str(open_error(path, exc))})
            continue
        try:
            out.append({"path": path, "caps": caps_from_device(dev)})
        finally:
            dev.close()
    return out


def find_evdev_node(name: str, vid: int, pid: int, root: str = "/dev/input",
                    opener: Callable[[str], EvdevNode] | None = None) -> str | None:
    """The event node of the device with this name and ids (after a replug it may have
    another ``eventN``), or None."""
    for entry in list_evdev(root, opener):
        caps = entry.get("caps")
        if caps is not None and (caps.name, caps.vid, caps.pid) == (name, vid, pid):
            return str(entry["path"])
    return None
