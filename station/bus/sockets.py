"""Binding or connecting one bus socket: CURVE on tcp, checked ipc socket files."""

from __future__ import annotations

import errno
import os
from pathlib import Path

import zmq

from station.bus.endpoints import Endpoint, EndpointInUse, ipc_in_use, secure_dir
from station.bus.keys import KeyCheck, secure_socket
from station.errors import BusError

HWM = 100_000  # ~100 s of one 1 kHz device: never drops in normal use, bounds memory (~12 MB)


def attach(sock: zmq.Socket[bytes], endpoint: Endpoint, keys_directory: Path | None,
           client: str | None = None) -> KeyCheck | None:
    """Bind or connect ``sock`` (CURVE first on tcp); a bound ipc socket file that a
    live process holds is refused (:class:`EndpointInUse`).  Returns the ZAP check of
    a bound tcp endpoint, else ``None``."""
    check = secure_socket(sock, endpoint, keys_directory, client)
    try:
        if endpoint.bind:
            if endpoint.url.startswith("ipc://"):
                path = Path(endpoint.url[6:])
                if endpoint.private:  # our own runtime directory: 0700, checked
                    secure_dir(path.parent)
                elif not path.parent.is_dir():  # an environment problem (exit 1), as before
                    raise BusError(f"directory {path.parent} of {endpoint.url} does not exist")
                if ipc_in_use(path):
                    raise EndpointInUse(f"{endpoint.url} is in use by another live process "
                                        "(a second driver or sim?); stop it or pick another "
                                        "endpoint")
            sock.bind(endpoint.url)
            if endpoint.url.startswith("ipc://"):
                os.chmod(endpoint.url[6:], 0o600)  # the socket we just made, nothing else
        else:
            sock.connect(endpoint.url)
    except zmq.ZMQError as exc:
        if endpoint.bind and exc.errno == errno.EADDRINUSE:
            raise EndpointInUse(f"{endpoint.url} is in use by another process") from None
        verb = "bind" if endpoint.bind else "connect"
        raise BusError(f"cannot {verb} {endpoint.url}: {exc}") from None
    return check

