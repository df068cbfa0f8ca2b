"""Where the bus lives: runtime and key directories, endpoint specs, ipc socket files.

An endpoint spec (``ipc``, ``ipc:NAME``, ``ipc:///abs/path``, ``tcp://HOST:PORT``,
with ``@`` forcing bind and ``>`` forcing connect) resolves to an :class:`Endpoint`;
:func:`ipc_in_use` tells a live process's socket file from a stale one, and
:func:`wait_released` waits until a socket this process closed is let go.
"""

from __future__ import annotations

import errno
import os
import socket
import stat
import time
from dataclasses import dataclass
from pathlib import Path

from station import paths
from station.errors import BusConfigError, BusError

DEFAULT_NAME = "bus"


class EndpointInUse(BusConfigError):
    """Another live process already binds the endpoint (bad input: exit 2)."""



# -- where things live -------------------------------------------------------
def runtime_dir() -> Path:
    """The per-user runtime directory for ipc sockets, created 0700 and checked.

    ``$STATION_RUNTIME_DIR``, else ``$XDG_RUNTIME_DIR/station``, else
    ``/tmp/station-<uid>``.  Refuses a directory another user owns or others
    can enter.
    """
    if os.environ.get("STATION_RUNTIME_DIR"):
        # the user named it: checked, refused if unsafe, never chmod-ed
        return secure_dir(paths.runtime_base(), repair=False)
    return secure_dir(paths.runtime_base())


def secure_dir(path: Path, repair: bool = True) -> Path:
    """Create ``path`` with mode 0700 (or check an existing one).

    An existing directory open to others is set to 0700 when it is the station's
    own (``repair``); one the user named is refused instead, never chmod-ed.
    """
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
        st = path.lstat()
    except OSError as exc:
        raise BusError(f"cannot create runtime directory {path}: {exc.strerror}") from None
    if not stat.S_ISDIR(st.st_mode):
        raise BusError(f"{path} is not a directory")
    if st.st_uid != os.getuid():
        raise BusError(f"{path} belongs to uid {st.st_uid}, not to you: refusing to use it")
    if st.st_mode & 0o077:
        if not repair:
            raise BusConfigError(f"{path} is open to other users (mode "
                                 f"{stat.S_IMODE(st.st_mode):o}); chmod 700 it yourself or "
                                 "use another directory")
        os.chmod(path, 0o700)
    return path


def config_dir() -> Path:
    return paths.config_dir()


def keys_dir() -> Path:
    return config_dir() / "keys"


@dataclass(frozen=True)
class Endpoint:
    """A resolved endpoint: the ZeroMQ URL and whether this side binds."""

    url: str
    bind: bool
    private: bool = False  # an ipc socket in the station's own runtime directory

    @property
    def is_tcp(self) -> bool:
        return self.url.startswith("tcp://")


def resolve_endpoint(spec: str | None, bind: bool) -> Endpoint:
    """Turn an endpoint spec (see module docstring) into an :class:`Endpoint`."""
    spec = (spec or "ipc").strip()
    if spec.startswith("@"):
        bind, spec = True, spec[1:]
    elif spec.startswith(">"):
        bind, spec = False, spec[1:]
    if spec == "ipc" or (spec.startswith("ipc:") and not spec.startswith("ipc://")):
        name = spec[4:] or DEFAULT_NAME
        if not name.replace("-", "").replace("_", "").replace(".", "").isalnum():
            raise BusConfigError(f"ipc bus name {name!r} must be letters, digits, - _ .")
        return Endpoint(f"ipc://{runtime_dir() / name}", bind, private=True)
    if spec.startswith("ipc://"):
        # A directory the user named is used as it is: never created, never chmod-ed
        # (on a shared /tmp or /run that would break every other user and service).
        path = Path(spec[6:])
        if not path.is_absolute():
            raise BusConfigError(f"ipc endpoint {spec!r} needs an absolute path")
        return Endpoint(spec, bind)
    if spec.startswith("tcp://"):
        hostport = spec[6:]
        host, sep, port = hostport.rpartition(":")
        if not sep or not port.isdigit() or not 0 < int(port) < 65536:
            raise BusConfigError(f"tcp endpoint {spec!r} needs a port: tcp://HOST:PORT")
        if host in ("", "*"):
            host = "127.0.0.1"  # loopback unless an address is given explicitly
        return Endpoint(f"tcp://{host}:{port}", bind)
    raise BusConfigError(f"unknown endpoint {spec!r} (use ipc, ipc:NAME, ipc:///path, tcp://HOST:PORT)")



def ipc_in_use(path: Path) -> bool:
    """Whether a live process answers on the ipc socket file ``path``.

    ZeroMQ unlinks whatever is at the path when it binds, so without this check a
    second publisher silently steals the endpoint.  A socket nobody accepts on
    (its process died) is stale and may be replaced; a path that is not a socket
    is never replaced.
    """
    try:
        st = path.lstat()
    except FileNotFoundError:
        return False
    except OSError as exc:
        raise BusError(f"cannot inspect {path}: {exc.strerror}") from None
    if not stat.S_ISSOCK(st.st_mode):
        raise BusConfigError(f"{path} exists and is not a socket: refusing to replace it")
    probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    probe.settimeout(1.0)
    try:
        probe.connect(str(path))
    except OSError as exc:
        return exc.errno not in (errno.ECONNREFUSED, errno.ENOENT)
    finally:
        probe.close()
    return True



#: How long a close waits for zmq's I/O thread to let go of a bound ipc socket file.
RELEASE_WAIT_S = 1.0


def wait_released(endpoints: list[Endpoint]) -> None:
    """Wait until nobody answers on the ipc socket files these bound endpoints made.
    zmq closes a listener in its I/O thread, after ``close`` returned: meanwhile the
    file still answers, so the next bind in this process (a restarted component, a
    second run of a command) would take it for another live process
    (:func:`ipc_in_use`)."""
    deadline = time.monotonic() + RELEASE_WAIT_S
    for ep in endpoints:
        if not (ep.bind and ep.url.startswith("ipc://")):
            continue
        path = Path(ep.url[6:])
        try:
            while ipc_in_use(path) and time.monotonic() < deadline:
                time.sleep(0.002)
        except (BusError, BusConfigError):  # replaced meanwhile: not ours to wait for
            continue

