"""CURVE keys and the ZAP check of who may connect over tcp.

:func:`generate_keys` and :func:`add_client_key` write key pairs; :func:`load_keys`
reads them for a server or a client; :func:`secure_socket` makes a tcp socket a
CURVE server (checking clients through a per-context ZAP handler, one domain per
key directory) or a CURVE client; :class:`HandshakeWatch` tells a connecting
client that the server refused its key.
"""

from __future__ import annotations

import hashlib
import logging
import os
import stat
import struct
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zmq
import zmq.auth

from station.bus.endpoints import Endpoint, keys_dir, secure_dir
from station.errors import BusConfigError

log = logging.getLogger("station.bus")  # one logger for the whole bus, as before the split


# -- CURVE keys ----------------------------------------------------------------
def generate_keys(directory: Path | None = None, force: bool = False) -> dict[str, Path]:
    """Create the server and client key pairs and authorise the client.

    Layout: ``server.key``/``server.key_secret``, ``client.key``/``client.key_secret``,
    ``authorized/client.key`` (public keys allowed to connect).
    """
    repair = directory is None  # a directory the user named is checked, never chmod-ed
    directory = directory or keys_dir()
    secure_dir(directory, repair)
    authorized = secure_dir(directory / "authorized", repair)
    paths: dict[str, Path] = {}
    for name in ("server", "client"):
        public = directory / f"{name}.key"
        if public.exists() and not force:
            raise BusConfigError(f"{public} exists; pass --force to replace the keys")
        pub, sec = zmq.auth.create_certificates(str(directory), name)
        os.chmod(sec, 0o600)
        paths[name] = Path(pub)
    (authorized / "client.key").write_bytes(paths["client"].read_bytes())
    paths["authorized"] = authorized
    return paths


@dataclass
class CurveKeys:
    public: bytes
    secret: bytes
    server_public: bytes
    authorized_dir: Path


def client_key_name(name: str) -> str:
    """Check a per-device client key name (it becomes a file name)."""
    if not name or not name.replace("-", "").replace("_", "").isalnum() or len(name) > 64:
        raise BusConfigError(f"client key name {name!r} must be 1-64 letters, digits, - _")
    return name


def add_client_key(name: str, directory: Path | None = None, force: bool = False) -> Path:
    """A key pair of its own for one driver: ``client-NAME.key[_secret]``, authorised.

    Revoke it by deleting ``authorized/client-NAME.key``.
    """
    repair = directory is None
    directory = directory or keys_dir()
    base = f"client-{client_key_name(name)}"
    if not (directory / "server.key").exists():
        raise BusConfigError(f"no server key in {directory}; run 'station keys' first")
    public = directory / f"{base}.key"
    if public.exists() and not force:
        raise BusConfigError(f"{public} exists; pass --force to replace it")
    secure_dir(directory, repair)
    authorized = secure_dir(directory / "authorized", repair)
    pub, sec = zmq.auth.create_certificates(str(directory), base)
    os.chmod(sec, 0o600)
    (authorized / f"{base}.key").write_bytes(Path(pub).read_bytes())
    return Path(pub)


def check_private(directory: Path, secret: Path) -> None:
    """Refuse (one line saying what to chmod) a secret key others can read, or a
    keys directory others can enter or write: either lets another user on the
    machine take the key and join the bus as the station."""
    for path, want, is_dir in ((directory, 0o700, True), (secret, 0o600, False)):
        try:
            st = path.lstat()
        except FileNotFoundError:
            return  # missing keys: load_keys says so
        except OSError as exc:
            raise BusConfigError(f"cannot read {path}: {exc.strerror}") from None
        kind_ok = stat.S_ISDIR(st.st_mode) if is_dir else stat.S_ISREG(st.st_mode)
        if not kind_ok:
            raise BusConfigError(f"{path} is not a {'directory' if is_dir else 'file'}: "
                                 "refusing it as a CURVE key")
        if st.st_mode & 0o077:
            raise BusConfigError(
                f"{path} is open to other users (mode {stat.S_IMODE(st.st_mode):o}): "
                f"chmod {want:o} {path}")


def load_keys(directory: Path | None = None, role: str = "server",
              client: str | None = None) -> CurveKeys:
    """Keys for a CURVE server (``server.key_secret``), or for a client: the server's
    public ``server.key`` and ``client.key_secret`` or, with ``client=NAME``, that
    client's own ``client-NAME.key_secret``."""
    directory = directory or keys_dir()
    secret_name = "server.key_secret" if role == "server" else \
        f"client-{client_key_name(client)}.key_secret" if client else "client.key_secret"
    check_private(directory, directory / secret_name)
    try:
        if role == "server":
            server_pub, sec = zmq.auth.load_certificate(str(directory / "server.key_secret"))
            pub = server_pub
        else:
            # A client needs the server's public key only: the machine a kiosk or a
            # remote driver runs on never holds the server's secret.
            server_pub, _ = zmq.auth.load_certificate(str(directory / "server.key"))
            base = f"client-{client_key_name(client)}" if client else "client"
            pub, sec = zmq.auth.load_certificate(str(directory / f"{base}.key_secret"))
    except (OSError, ValueError) as exc:
        raise BusConfigError(
            f"no usable CURVE keys in {directory} ({exc}); run 'station keys' first"
        ) from None
    if sec is None or server_pub is None:
        raise BusConfigError(f"secret key missing in {directory}; run 'station keys --force'")
    return CurveKeys(pub, sec, server_pub, directory / "authorized")



_auth_lock = threading.Lock()
_authenticators: dict[int, Any] = {}  # context id -> its ThreadAuthenticator
_key_checks: dict[tuple[int, str], KeyCheck] = {}  # (context, ZAP domain) -> its check


MAX_REJECTED_KEYS = 256  # distinct refused client keys named (and logged) one by one


class KeyCheck:
    """The ZAP handler's verdict on a CURVE client: allowed if its public key is in
    the authorised directory (read at every connection, so a key added or revoked
    counts at once); a rejected peer is logged with its public key, once per key."""

    def __init__(self, authorized_dir: Path) -> None:
        self.authorized_dir = authorized_dir
        self.rejected: dict[str, int] = {}  # z85 public key -> connection attempts
        self.unnamed = 0  # rejections past MAX_REJECTED_KEYS distinct keys
        self.refused = 0  # all of them (read from other threads: one int, no iteration)

    def allowed_keys(self) -> set[bytes]:
        try:
            return set(zmq.auth.load_certificates(str(self.authorized_dir)))
        except (OSError, ValueError) as exc:
            log.error("cannot read authorised keys in %s: %s", self.authorized_dir, exc)
            return set()

    def callback(self, domain: str, key: bytes) -> bool:
        if key in self.allowed_keys():
            return True
        text = key.decode("ascii", "replace")
        self.refused += 1
        if text not in self.rejected and len(self.rejected) >= MAX_REJECTED_KEYS:
            # any client may try any key: past this many, counted in `refused` only
            if self.unnamed == 0:
                log.warning("rejected CURVE peers with more than %d distinct keys: counting "
                            "the rest without naming them", MAX_REJECTED_KEYS)
            self.unnamed += 1
            return False
        self.rejected[text] = self.rejected.get(text, 0) + 1
        if self.rejected[text] == 1:
            log.warning("rejected a CURVE peer with public key %s (not in %s)", text,
                        self.authorized_dir)
        return False


def secure_socket(sock: zmq.Socket[bytes], endpoint: Endpoint, keys_directory: Path | None,
                  client: str | None = None) -> KeyCheck | None:
    """CURVE on tcp: the binding side is the server and checks client keys (the
    :class:`KeyCheck` it returns counts the peers it turned away)."""
    if not endpoint.is_tcp:
        return None
    if endpoint.bind:
        keys = load_keys(keys_directory, "server")
        ctx = sock.context
        # One ZAP handler per context; each key directory is a ZAP domain of its own,
        # so two endpoints bound with different --keys each check their own clients.
        domain = "station-" + hashlib.sha256(str(keys.authorized_dir).encode()).hexdigest()[:16]
        with _auth_lock:
            auth = _authenticators.get(id(ctx))
            if auth is None:
                # here, not at the top: it brings asyncio (15 ms), which the processes
                # that never bind tcp (every `station send`, ≤ 0.3 s a call) do not need
                from zmq.auth.thread import ThreadAuthenticator

                auth = ThreadAuthenticator(ctx, log=logging.getLogger("station.bus.zap"))
                auth.start()
                _authenticators[id(ctx)] = auth
            check = _key_checks.get((id(ctx), domain))
            if check is None:
                check = _key_checks[(id(ctx), domain)] = KeyCheck(keys.authorized_dir)
                auth.configure_curve_callback(domain=domain, credentials_provider=check)
        sock.zap_domain = domain.encode()
        sock.curve_secretkey = keys.secret
        sock.curve_publickey = keys.public
        sock.curve_server = True
        return check
    else:
        keys = load_keys(keys_directory, "client", client)
        sock.curve_secretkey = keys.secret
        sock.curve_publickey = keys.public
        sock.curve_serverkey = keys.server_public
        return None



def refused_count(checks: list[KeyCheck]) -> int:
    """Connections these ZAP checks turned away, all together."""
    return sum(c.refused for c in checks)



#: A connecting CURVE client learns only through its socket's events that the server
#: refused its key (ZAP status 400 arrives as a failed handshake).
HANDSHAKE_FAILED = (zmq.EVENT_HANDSHAKE_FAILED_AUTH | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
                    | zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL)


def _monitor_event(frames: list[bytes]) -> int:
    """The event of a socket monitor's message (first frame: uint16 event, uint32
    value), read here: pyzmq's own reader imports asyncio, 18 ms of every
    ``station send``."""
    return int(struct.unpack("=hi", frames[0][:6])[0]) if frames and len(frames[0]) >= 6 else 0


class HandshakeWatch:
    """The handshakes of a socket's connecting tcp endpoints: a CURVE server that
    refuses this client's key says so only by failing the handshake, and the socket
    would otherwise wait for a peer forever as if none listened."""

    def __init__(self, sock: zmq.Socket[bytes], endpoints: list[Endpoint]) -> None:
        self._sock = sock
        self.refusals = 0
        self._monitor = (sock.get_monitor_socket(HANDSHAKE_FAILED)
                         if any(not e.bind and e.url.startswith("tcp://") for e in endpoints)
                         else None)

    def refused(self) -> bool:
        """Whether a handshake failed since the last call (counted in :attr:`refusals`)."""
        refused = False
        while self._monitor is not None and self._monitor.poll(0, zmq.POLLIN):
            if _monitor_event(self._monitor.recv_multipart()) & HANDSHAKE_FAILED:
                self.refusals += 1
                refused = True
        return refused

    def close(self) -> None:
        if self._monitor is not None:
            self._sock.disable_monitor()
            self._monitor.close(linger=0)
            self._monitor = None

