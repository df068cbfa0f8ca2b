"""The station bus: ZeroMQ publish/subscribe of pen samples, commands, status.

Topics: ``pen.<device>`` (pen samples), ``cmd`` (commands to the simulation),
``status`` (JSON status of any process), ``haptic.<device>`` (force
back-channel).  Payloads use :mod:`station.wire`.

Endpoints (``EndpointSpec``): ``ipc`` (the default, ``ipc://<runtime>/bus``),
``ipc:NAME`` (``ipc://<runtime>/NAME``), ``ipc:///abs/path``, ``tcp://HOST:PORT``
(always CURVE-authenticated; ``tcp://:PORT`` binds loopback only).  A leading
``@`` forces bind, ``>`` forces connect (the CZMQ convention); by default
publishers bind and subscribers connect.  ``station bus`` runs a proxy for
many-to-many set-ups: publishers connect to its ``pub`` endpoint, subscribers
to its ``sub`` endpoint.

Late joiners: publishers use XPUB and see each new subscription; they then
re-send the samples of the current proximity period (flagged *replayed*) so a
subscriber that starts mid-stroke still sees the stroke from its first sample.
Subscribers drop replayed messages they already have (by sequence number) and
count gaps in the per-publisher, per-topic sequence as lost samples.

Truth about who is there: binding an endpoint that a live process already
holds fails (:class:`EndpointInUse`, exit 2) instead of taking it over (an ipc
socket file whose process died is replaced); a publisher created with
``heartbeat=S`` sends a heartbeat per device every ``S`` seconds on
``hb.<device>`` (:meth:`Publisher.tick`), so a subscriber notices a publisher
that stopped, and samples lost at the very end of its stream.
"""

from __future__ import annotations

import collections
import errno
import hashlib
import logging
import os
import random
import socket
import stat
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zmq
from zmq.utils.monitor import recv_monitor_message

from station import sdnotify, wire
from station.errors import BusConfigError, BusError, WireError
from station.events import Command, PenSample

log = logging.getLogger(__name__)

HWM = 100_000  # ~100 s of one 1 kHz device: never drops in normal use, bounds memory (~12 MB)
REPLAY_LIMIT = 4096  # samples kept per pen topic for late joiners (20 s at 200 Hz)
DEFAULT_NAME = "bus"
HEARTBEAT_S = 0.2  # drivers' heartbeat interval: a silent device is named within ~1 s


class EndpointInUse(BusConfigError):
    """Another live process already binds the endpoint (bad input: exit 2)."""


# -- where things live -------------------------------------------------------
def runtime_dir() -> Path:
    """The per-user runtime directory for ipc sockets, created 0700 and checked.

    ``$STATION_RUNTIME_DIR``, else ``$XDG_RUNTIME_DIR/station``, else
    ``/tmp/station-<uid>``.  Refuses a directory another user owns or others
    can enter.
    """
    base = os.environ.get("STATION_RUNTIME_DIR")
    if base:  # the user named it: checked, refused if unsafe, never chmod-ed
        return secure_dir(Path(base), repair=False)
    if os.environ.get("XDG_RUNTIME_DIR") and Path(os.environ["XDG_RUNTIME_DIR"]).is_dir():
        path = Path(os.environ["XDG_RUNTIME_DIR"]) / "station"
    else:
        path = Path(f"/tmp/station-{os.getuid()}")
    return secure_dir(path)


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
    base = os.environ.get("STATION_CONFIG_DIR")
    if base:
        return Path(base)
    xdg = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(xdg) / "station"


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


# -- CURVE keys ----------------------------------------------------------------
def generate_keys(directory: Path | None = None, force: bool = False) -> dict[str, Path]:
    """Create the server and client key pairs and authorise the client.

    Layout: ``server.key``/``server.key_secret``, ``client.key``/``client.key_secret``,
    ``authorized/client.key`` (public keys allowed to connect).
    """
    import zmq.auth

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
    import zmq.auth

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
    import zmq.auth

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
_authenticators: dict[int, Any] = {}
_key_checks: dict[tuple[int, str], KeyCheck] = {}  # (context, ZAP domain) -> its check


class KeyCheck:
    """The ZAP handler's verdict on a CURVE client: allowed if its public key is in
    the authorised directory (read at every connection, so a key added or revoked
    counts at once); a rejected peer is logged with its public key, once per key."""

    def __init__(self, authorized_dir: Path) -> None:
        self.authorized_dir = authorized_dir
        self.rejected: dict[str, int] = {}  # z85 public key -> connection attempts
        self.refused = 0  # all of them (read from other threads: one int, no iteration)

    def allowed_keys(self) -> set[bytes]:
        import zmq.auth

        try:
            return set(zmq.auth.load_certificates(str(self.authorized_dir)))
        except (OSError, ValueError) as exc:
            log.error("cannot read authorised keys in %s: %s", self.authorized_dir, exc)
            return set()

    def callback(self, domain: str, key: bytes) -> bool:
        if key in self.allowed_keys():
            return True
        text = key.decode("ascii", "replace")
        self.rejected[text] = self.rejected.get(text, 0) + 1
        self.refused += 1
        if self.rejected[text] == 1:
            log.warning("rejected a CURVE peer with public key %s (not in %s)", text,
                        self.authorized_dir)
        return False


def _secure(sock: zmq.Socket, endpoint: Endpoint, keys_directory: Path | None,
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


def _attach(sock: zmq.Socket, endpoint: Endpoint, keys_directory: Path | None,
            client: str | None = None) -> KeyCheck | None:
    check = _secure(sock, endpoint, keys_directory, client)
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


#: How long a close waits for zmq's I/O thread to let go of a bound ipc socket file.
RELEASE_WAIT_S = 1.0


def _wait_released(endpoints: list[Endpoint]) -> None:
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


def _rejected(checks: list[KeyCheck]) -> int:
    return sum(c.refused for c in checks)


#: A connecting CURVE client learns only through its socket's events that the server
#: refused its key (ZAP status 400 arrives as a failed handshake).
HANDSHAKE_FAILED = (zmq.EVENT_HANDSHAKE_FAILED_AUTH | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
                    | zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL)


class HandshakeWatch:
    """The handshakes of a socket's connecting tcp endpoints: a CURVE server that
    refuses this client's key says so only by failing the handshake, and the socket
    would otherwise wait for a peer forever as if none listened."""

    def __init__(self, sock: zmq.Socket, endpoints: list[Endpoint]) -> None:
        self._sock = sock
        self.refusals = 0
        self._monitor = (sock.get_monitor_socket(HANDSHAKE_FAILED)
                         if any(not e.bind and e.url.startswith("tcp://") for e in endpoints)
                         else None)

    def refused(self) -> bool:
        """Whether a handshake failed since the last call (counted in :attr:`refusals`)."""
        refused = False
        while self._monitor is not None and self._monitor.poll(0, zmq.POLLIN):
            if recv_monitor_message(self._monitor)["event"] & HANDSHAKE_FAILED:
                self.refusals += 1
                refused = True
        return refused

    def close(self) -> None:
        if self._monitor is not None:
            self._sock.disable_monitor()
            self._monitor.close(linger=0)
            self._monitor = None


# -- publisher ------------------------------------------------------------------
class Publisher:
    """Publishes on the bus.  Thread-compatible, not thread-safe (one per thread)."""

    def __init__(
        self,
        endpoint: str | None = None,
        bind: bool = True,
        keys: Path | None = None,
        context: zmq.Context | None = None,
        replay: bool = True,
        heartbeat: float | None = None,
        client_key: str | None = None,
    ) -> None:
        self.endpoint = resolve_endpoint(endpoint, bind)
        self.ctx = context or zmq.Context.instance()
        self.sock = self.ctx.socket(zmq.XPUB)
        self.sock.setsockopt(zmq.SNDHWM, HWM)
        self.sock.setsockopt(zmq.XPUB_VERBOSE, 1)  # see every subscription: late-joiner replay
        self.sock.setsockopt(zmq.LINGER, 1000)
        # watched before it connects: libzmq does not retry a refused handshake
        self._handshakes = HandshakeWatch(self.sock, [self.endpoint])
        try:
            check = _attach(self.sock, self.endpoint, keys, client_key)
        except BaseException:
            self._handshakes.close()
            self.sock.close(linger=0)
            raise
        self._key_checks = [check] if check is not None else []
        self.publisher_id = random.SystemRandom().getrandbits(32)
        if heartbeat is not None and not 0.0 < heartbeat <= wire.MAX_HEARTBEAT_INTERVAL:
            raise BusConfigError(f"heartbeat interval {heartbeat!r} s outside (0, "
                                 f"{wire.MAX_HEARTBEAT_INTERVAL:g}]")
        self.heartbeat_interval = heartbeat
        self._hb_devices: set[str] = set()
        self._next_heartbeat = 0.0
        self._seq: dict[str, int] = collections.defaultdict(int)
        self._recent: dict[str, collections.deque[list[bytes]]] = {}
        self.replay_enabled = replay
        self.subscriptions = 0
        self.replayed = 0
        self._topics: set[bytes] = set()  # the prefixes subscribers hold now

    @property
    def url(self) -> str:
        return self.endpoint.url

    @property
    def curve_rejected(self) -> int:
        """Connections refused because the client's key is not authorised (0 unless
        this publisher binds tcp; shared by the process's endpoints bound with the
        same key directory)."""
        return _rejected(self._key_checks)

    def _send(self, topic: str, value: Any) -> int:
        sdnotify.alive()  # a publishing loop that runs feeds systemd's watchdog
        # Reading ZMQ_EVENTS makes libzmq apply pending subscriptions now, so a new
        # subscriber gets its replay before this sample, never after it.
        if self.sock.get(zmq.EVENTS) & zmq.POLLIN:
            self._serve_subscriptions()
        seq = self._seq[topic] + 1
        self._seq[topic] = seq
        frames = wire.encode(topic, value, self.publisher_id, seq)
        self.sock.send_multipart(frames)
        if self.replay_enabled and isinstance(value, PenSample):
            recent = self._recent.get(topic)
            if recent is None:
                recent = self._recent[topic] = collections.deque(maxlen=REPLAY_LIMIT)
            if not value.proximity:
                recent.clear()  # a new proximity period starts after this sample
            else:
                recent.append(frames)
        elif self.replay_enabled and isinstance(value, dict):
            self._recent[topic] = collections.deque([frames], maxlen=1)
        return seq

    def publish_pen(self, sample: PenSample) -> int:
        """Publish on ``pen.<device>``; returns the bus sequence number."""
        seq = self._send(f"pen.{sample.device}", sample)
        if self.heartbeat_interval is not None:
            self._hb_devices.add(sample.device)
            self.tick()
        return seq

    def publish_pens(self, samples: list[PenSample]) -> int:
        """Publish samples that are ready together (a replay at full speed, a burst
        read from a device) in batch messages of up to ``wire.MAX_BATCH`` per
        device; each sample still takes its own sequence number, so loss counting
        and late-joiner replay work as for single samples.  Returns the last
        sequence number."""
        if self.sock.get(zmq.EVENTS) & zmq.POLLIN:
            self._serve_subscriptions()
        last = 0
        by_topic: dict[str, list[PenSample]] = {}
        for s in samples:
            by_topic.setdefault(f"pen.{s.device}", []).append(s)
        for topic, group in by_topic.items():
            for start in range(0, len(group), wire.MAX_BATCH):
                chunk = group[start : start + wire.MAX_BATCH]
                seq = self._seq[topic] + 1
                self._seq[topic] = seq + len(chunk) - 1
                self.sock.send_multipart(
                    wire.encode_pen_batch(topic, chunk, self.publisher_id, seq)
                )
                last = seq + len(chunk) - 1
                if self.replay_enabled:
                    self._remember_batch(topic, chunk, seq)
        if self.heartbeat_interval is not None:
            self._hb_devices.update(s.device for s in samples)
            self.tick()
        return last

    def _remember_batch(self, topic: str, chunk: list[PenSample], seq: int) -> None:
        recent = self._recent.get(topic)
        if recent is None:
            recent = self._recent[topic] = collections.deque(maxlen=REPLAY_LIMIT)
        for i, s in enumerate(chunk):
            if not s.proximity:
                recent.clear()
            else:  # kept one per sample, as single messages, like publish_pen's
                recent.append(wire.encode(topic, s, self.publisher_id, seq + i))

    def publish_cmd(self, command: Command) -> int:
        return self._send("cmd", command)

    def publish_status(self, status: dict[str, Any], topic: str = "status") -> int:
        return self._send(topic, status)

    def publish_haptic(self, device: str, haptic: wire.Haptic | wire.HapticForce) -> int:
        return self._send(f"haptic.{device}", haptic)

    # -- heartbeats ----------------------------------------------------------------
    def announce(self, device: str) -> None:
        """Send heartbeats for ``device`` from now on, before its first sample."""
        if self.heartbeat_interval is not None:
            self._hb_devices.add(device)

    def tick(self, force: bool = False) -> None:
        """Send the heartbeats that are due; call it from the publishing loop, idle
        or not (a heartbeat says the process is alive, so no thread sends it).
        ``force`` sends them now (a stream's end: the last ``pen_seq`` goes out)."""
        sdnotify.alive()
        if self.heartbeat_interval is None or not self._hb_devices:
            return
        now = time.monotonic()
        if now < self._next_heartbeat and not force:
            return
        self._next_heartbeat = now + self.heartbeat_interval
        for device in sorted(self._hb_devices):
            hb = wire.Heartbeat(self.heartbeat_interval, self._seq.get(f"pen.{device}", 0))
            self._send(f"hb.{device}", hb)

    def _serve_subscriptions(self) -> None:
        while True:
            try:
                msg = self.sock.recv(zmq.NOBLOCK)
            except zmq.Again:
                return
            if not msg or msg[0] not in (0, 1):
                continue
            prefix = msg[1:]
            if msg[0] == 0:  # the last subscriber of this prefix left
                self._topics.discard(prefix)
                continue
            self.subscriptions += 1
            self._topics.add(prefix)
            for topic, frames in self._recent.items():
                if topic.encode().startswith(prefix):
                    for fr in frames:
                        header = bytearray(fr[1][: wire.HEADER_SIZE])
                        header[4] |= wire.FLAG_REPLAY
                        self.sock.send_multipart([fr[0], bytes(header) + fr[1][wire.HEADER_SIZE:]])
                        self.replayed += 1

    def wants(self, topic: str) -> bool:
        """Whether a subscriber asked for ``topic`` by a prefix of it other than ``""``
        (a subscriber of everything does not count): a publisher skips costly messages
        nobody asked for (the sim's haptic forces)."""
        self._serve_subscriptions()
        t = topic.encode()
        return any(p and t.startswith(p) for p in self._topics)

    def poll_subscriptions(self) -> None:
        """Serve pending subscriptions (late-joiner replay) without publishing."""
        self._serve_subscriptions()

    def wait_for_subscribers(self, count: int = 1, timeout: float = 5.0) -> bool:
        """Block until ``count`` subscriptions arrived (a connection handshake);
        ``False`` after ``timeout`` or as soon as the peer refuses this client's key
        (:attr:`refusals`)."""
        deadline = time.monotonic() + timeout
        while self.subscriptions < count:
            if time.monotonic() > deadline:
                return False
            if self.sock.poll(20, zmq.POLLIN):
                self._serve_subscriptions()
            if self._handshakes.refused():
                return False
        return True

    @property
    def refusals(self) -> int:
        """Handshakes the peer refused (a tcp client whose CURVE key it does not know)."""
        return self._handshakes.refusals

    def close(self) -> None:
        self._handshakes.close()
        self.sock.close()
        _wait_released([self.endpoint])

    def __enter__(self) -> Publisher:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# -- subscriber -----------------------------------------------------------------
@dataclass
class SubscriberStats:
    """Counters of one subscriber; all integers count messages."""

    received: int = 0
    lost: int = 0  # samples and commands (heartbeats are not counted as lost)
    heartbeats: int = 0
    duplicates: int = 0
    malformed: int = 0
    foreign: int = 0
    version_mismatch: int = 0
    started_at: dict[str, int] = field(default_factory=dict)  # "topic@publisher" -> first seq
    refused_by_peer: int = 0  # handshakes a publisher refused (our CURVE key, connecting)
    # the ZAP checks of the tcp endpoints this subscriber binds (CURVE server)
    key_checks: list[KeyCheck] = field(default_factory=list, repr=False)

    @property
    def curve_rejected(self) -> int:
        """Connections refused for a client key not authorised (0 unless bound on tcp)."""
        return _rejected(self.key_checks)

    def as_dict(self) -> dict[str, Any]:
        return {
            "received": self.received, "lost": self.lost, "heartbeats": self.heartbeats,
            "duplicates": self.duplicates,
            "malformed": self.malformed, "foreign": self.foreign,
            "version_mismatch": self.version_mismatch, "started_at": dict(self.started_at),
            "curve_rejected": self.curve_rejected, "refused_by_peer": self.refused_by_peer,
        }  # fmt: skip


@dataclass(frozen=True, slots=True)
class Message:
    """What :meth:`Subscriber.recv` returns."""

    topic: str
    kind: str  # 'pen' | 'cmd' | 'status' | 'haptic' | 'heartbeat'
    value: Any
    publisher: int
    seq: int
    replay: bool


class Subscriber:
    """Receives from the bus, decoding, de-duplicating and counting losses."""

    def __init__(
        self,
        endpoint: str | list[str] | None = None,
        topics: tuple[str, ...] = ("pen.", "cmd"),
        bind: bool = False,
        keys: Path | None = None,
        context: zmq.Context | None = None,
        client_key: str | None = None,
    ) -> None:
        specs = endpoint if isinstance(endpoint, list) else [endpoint]
        self.endpoints = [resolve_endpoint(s, bind) for s in specs]
        self.ctx = context or zmq.Context.instance()
        self.sock = self.ctx.socket(zmq.SUB)
        self.sock.setsockopt(zmq.RCVHWM, HWM)
        self.sock.setsockopt(zmq.LINGER, 0)
        for t in topics:
            self.sock.setsockopt(zmq.SUBSCRIBE, t.encode())
        self._key_checks: list[KeyCheck] = []
        self._handshakes = HandshakeWatch(self.sock, self.endpoints)  # before connecting
        try:
            for ep in self.endpoints:
                check = _attach(self.sock, ep, keys, client_key)
                if check is not None and check not in self._key_checks:
                    self._key_checks.append(check)
        except BaseException:
            self._handshakes.close()
            self.sock.close(linger=0)
            raise
        self.stats = SubscriberStats(key_checks=self._key_checks)
        self._last: dict[tuple[int, str], int] = {}
        self._pending: collections.deque[Message] = collections.deque()
        self._last_warning = 0.0

    @property
    def curve_rejected(self) -> int:
        """Connections refused because the client's key is not authorised (0 unless
        this subscriber binds tcp; see :attr:`Publisher.curve_rejected`)."""
        return self.stats.curve_rejected

    def _check_handshakes(self) -> None:
        """Count and say (once) that a publisher refused this client's key: nothing
        would ever arrive from it, and a quiet bus looks like an idle one."""
        if self._handshakes.refused():
            if self.stats.refused_by_peer == 0:
                urls = ", ".join(e.url for e in self.endpoints if e.url.startswith("tcp://"))
                log.warning("the publisher on %s refused this client's CURVE key: nothing "
                            "will arrive from it (authorise the key there)", urls)
            self.stats.refused_by_peer = self._handshakes.refusals

    def _drop(self, exc: WireError) -> None:
        text = str(exc)
        if text.startswith("foreign"):
            self.stats.foreign += 1
        elif text.startswith("wire version"):
            self.stats.version_mismatch += 1
        else:
            self.stats.malformed += 1
        now = time.monotonic()
        if now - self._last_warning > 1.0:  # rate-limited: a flood must not flood the log
            self._last_warning = now
            log.warning("dropped a bad bus message: %s", text)

    def recv(self, timeout_ms: int | None = 100) -> Message | None:
        """The next valid, new message, or ``None`` after ``timeout_ms``."""
        sdnotify.alive()
        if self._pending:
            return self._pending.popleft()
        deadline = None if timeout_ms is None else time.monotonic() + timeout_ms / 1000
        while True:
            try:
                frames = self.sock.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                wait = (None if deadline is None
                        else max(0, int((deadline - time.monotonic()) * 1000)))
                if not self.sock.poll(wait, zmq.POLLIN):
                    self._check_handshakes()
                    return None
                continue
            try:
                env = wire.decode(frames)
            except WireError as exc:
                self._drop(exc)
                continue
            if env.kind == "heartbeat":
                return self._heartbeat(env)
            key = (env.publisher, env.topic)
            last = self._last.get(key)
            end = env.seq + env.count - 1
            if last is None:
                self.stats.started_at[f"{env.topic}@{env.publisher:08x}"] = env.seq
            elif end <= last:
                self.stats.duplicates += env.count
                continue
            elif env.seq > last + 1:
                self.stats.lost += env.seq - last - 1
            self._last[key] = end
            if isinstance(env.value, list):  # a pen batch: one Message per new sample
                skip = 0 if last is None else max(0, last + 1 - env.seq)
                self.stats.duplicates += skip
                msgs = [Message(env.topic, "pen", v, env.publisher, env.seq + i, env.replay)
                        for i, v in enumerate(env.value) if i >= skip]
                self.stats.received += len(msgs)
                self._pending.extend(msgs[1:])
                return msgs[0]
            self.stats.received += 1
            return Message(env.topic, env.kind, env.value, env.publisher, env.seq, env.replay)

    def _heartbeat(self, env: wire.Envelope) -> Message:
        """A heartbeat: samples it says were sent that never came are lost."""
        self.stats.heartbeats += 1
        key = (env.publisher, "pen." + env.topic.partition(".")[2])
        last = self._last.get(key)
        if last is not None and env.value.pen_seq > last:
            self.stats.lost += env.value.pen_seq - last
            self._last[key] = env.value.pen_seq
        return Message(env.topic, "heartbeat", env.value, env.publisher, env.seq, env.replay)

    def close(self) -> None:
        self._handshakes.close()
        self.sock.close()
        _wait_released(self.endpoints)

    def __enter__(self) -> Subscriber:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# -- proxy ------------------------------------------------------------------------
def run_proxy(
    pub_side: str,
    sub_side: str,
    keys: Path | None = None,
    context: zmq.Context | None = None,
    stop: threading.Event | None = None,
) -> int:
    """Forward every publisher (connecting to ``pub_side``) to every subscriber
    (connecting to ``sub_side``) until ``stop`` is set or the context ends.

    Subscriptions travel upstream verbosely, so publishers still see each late
    joiner and replay for it.  Returns how many connections CURVE refused (a
    client key not authorised; 0 on ipc).
    """
    ctx = context or zmq.Context.instance()
    frontend = ctx.socket(zmq.XSUB)
    backend = ctx.socket(zmq.XPUB)
    for s in (frontend, backend):
        s.setsockopt(zmq.SNDHWM, HWM)
        s.setsockopt(zmq.RCVHWM, HWM)
        s.setsockopt(zmq.LINGER, 0)
    backend.setsockopt(zmq.XPUB_VERBOSE, 1)
    checks = [c for c in (_attach(frontend, resolve_endpoint(pub_side, True), keys),
                          _attach(backend, resolve_endpoint(sub_side, True), keys))
              if c is not None]
    poller = zmq.Poller()
    poller.register(frontend, zmq.POLLIN)
    poller.register(backend, zmq.POLLIN)
    try:
        while stop is None or not stop.is_set():
            sdnotify.alive()
            events = dict(poller.poll(100))
            if frontend in events:
                for _ in range(1000):
                    try:
                        backend.send_multipart(frontend.recv_multipart(zmq.NOBLOCK))
                    except zmq.Again:
                        break
            if backend in events:
                for _ in range(1000):
                    try:
                        frontend.send_multipart(backend.recv_multipart(zmq.NOBLOCK))
                    except zmq.Again:
                        break
    finally:
        frontend.close()
        backend.close()
    return _rejected(list({id(c): c for c in checks}.values()))
