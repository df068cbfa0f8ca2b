"""Publishers and subscribers of the bus: sequence numbers, late-joiner replay,
heartbeats, loss and duplicate counting (see :mod:`station.bus`)."""

from __future__ import annotations

import collections
import logging
import random
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import zmq

from station import sdnotify, wire
from station.bus.endpoints import resolve_endpoint, wait_released
from station.bus.keys import HandshakeWatch, KeyCheck, refused_count
from station.bus.sockets import HWM, attach
from station.errors import BusConfigError, WireError
from station.events import Command, PenSample

log = logging.getLogger("station.bus")  # one logger for the whole bus, as before the split

REPLAY_LIMIT = 4096  # samples kept per pen topic for late joiners (20 s at 200 Hz)
HEARTBEAT_S = 0.2  # drivers' heartbeat interval: a silent device is named within ~1 s
# Streams (publisher id, topic) a subscriber follows for loss and duplicate counting:
# both are chosen by whoever publishes, so the table is bounded; the stream heard least
# recently goes first (counted), and is counted afresh if it speaks again.
MAX_STREAMS = 4096
MAX_STARTED_AT = 256  # streams whose first sequence number the status reports
UPSTREAM_KEPT = 16  # messages a publisher keeps from its subscribers (command answers)
MAX_UPSTREAM_BYTES = 64 * 1024


# -- publisher ------------------------------------------------------------------
class Publisher:
    """Publishes on the bus.  Thread-compatible, not thread-safe (one per thread)."""

    def __init__(
        self,
        endpoint: str | None = None,
        bind: bool = True,
        keys: Path | None = None,
        context: zmq.Context[zmq.Socket[bytes]] | None = None,
        replay: bool = True,
        heartbeat: float | None = None,
        client_key: str | None = None,
    ) -> None:
        self.endpoint = resolve_endpoint(endpoint, bind)
        self.ctx = context or zmq.Context.instance()
        self.sock = self.ctx.socket(zmq.XPUB)
        self.sock.setsockopt(zmq.SNDHWM, HWM)
        # Subscriptions are applied by this publisher, not by libzmq: a subscription
        # libzmq applied by itself could take effect inside a send (libzmq processes
        # its commands there), so the new subscriber got that live sample before the
        # replay of the samples before it, and dropped the replay as duplicates (a CI
        # run at load saw it).  Applied where it is read, the replay always comes first.
        self.sock.setsockopt(zmq.XPUB_MANUAL, 1)
        self.sock.setsockopt(zmq.LINGER, 1000)
        # watched before it connects: libzmq does not retry a refused handshake
        self._handshakes = HandshakeWatch(self.sock, [self.endpoint])
        try:
            check = attach(self.sock, self.endpoint, keys, client_key)
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
        # the prefixes subscribers hold now, with how many hold each
        self._topics: collections.Counter[bytes] = collections.Counter()
        # what subscribers sent that is not a subscription: answers to commands, from a
        # Subscriber made with ``answers=True`` (bounded: a peer cannot grow it)
        self.upstream: collections.deque[bytes] = collections.deque(maxlen=UPSTREAM_KEPT)

    @property
    def url(self) -> str:
        return self.endpoint.url

    @property
    def curve_rejected(self) -> int:
        """Connections refused because the client's key is not authorised (0 unless
        this publisher binds tcp; shared by the process's endpoints bound with the
        same key directory)."""
        return refused_count(self._key_checks)

    def _send(self, topic: str, value: object) -> int:
        sdnotify.alive()  # a publishing loop that runs feeds systemd's watchdog
        # Reading ZMQ_EVENTS makes libzmq apply pending subscriptions now, so a new
        # subscriber gets its replay before this sample, never after it.
        if cast(int, self.sock.get(zmq.EVENTS)) & zmq.POLLIN:  # EVENTS is an int option
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
        if cast(int, self.sock.get(zmq.EVENTS)) & zmq.POLLIN:  # EVENTS is an int option
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

    def publish_status(self, status: Mapping[str, object], topic: str = "status") -> int:
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
                if msg and len(msg) <= MAX_UPSTREAM_BYTES:
                    self.upstream.append(msg)
                continue
            prefix = msg[1:]
            if msg[0] == 0:  # a subscriber dropped this prefix, or left
                # (a no-op in libzmq for a subscriber that is gone: its pipe's
                # subscriptions went with it)
                self.sock.setsockopt(zmq.UNSUBSCRIBE, prefix)
                self._topics[prefix] -= 1
                if self._topics[prefix] <= 0:
                    del self._topics[prefix]
                continue
            self.sock.setsockopt(zmq.SUBSCRIBE, prefix)  # only for the pipe it came from
            self.subscriptions += 1
            self._topics[prefix] += 1
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
        nobody asked for (the sim's haptic forces).  Behind a proxy, where several
        subscribers of one prefix arrive as several subscriptions but leave as one
        unsubscription (libzmq's XSUB forwards only the last), it can stay true after
        they all left: it errs towards sending, never stops a stream someone wants."""
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

    def recv_upstream(self, timeout: float) -> bytes | None:
        """The next message a subscriber sent back (see :attr:`upstream`), or ``None``
        after ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        while not self.upstream:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            if self.sock.poll(max(1, int(left * 1000)), zmq.POLLIN):
                self._serve_subscriptions()
        return self.upstream.popleft()

    @property
    def refusals(self) -> int:
        """Handshakes the peer refused (a tcp client whose CURVE key it does not know)."""
        return self._handshakes.refusals

    def close(self) -> None:
        self._handshakes.close()
        self.sock.close()
        wait_released([self.endpoint])

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
    streams_forgotten: int = 0  # streams let go beyond MAX_STREAMS (see there)
    # the ZAP checks of the tcp endpoints this subscriber binds (CURVE server)
    key_checks: list[KeyCheck] = field(default_factory=list, repr=False)

    @property
    def curve_rejected(self) -> int:
        """Connections refused for a client key not authorised (0 unless bound on tcp)."""
        return refused_count(self.key_checks)

    def as_dict(self) -> dict[str, object]:
        return {
            "received": self.received, "lost": self.lost, "heartbeats": self.heartbeats,
            "duplicates": self.duplicates,
            "malformed": self.malformed, "foreign": self.foreign,
            "version_mismatch": self.version_mismatch, "started_at": dict(self.started_at),
            "curve_rejected": self.curve_rejected, "refused_by_peer": self.refused_by_peer,
            "streams_forgotten": self.streams_forgotten,
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
        context: zmq.Context[zmq.Socket[bytes]] | None = None,
        client_key: str | None = None,
        answers: bool = False,
    ) -> None:
        specs = endpoint if isinstance(endpoint, list) else [endpoint]
        self.endpoints = [resolve_endpoint(s, bind) for s in specs]
        self.ctx = context or zmq.Context.instance()
        # answers: an XSUB, which can send back to its publishers over the connections
        # they opened (the answer to a command, :meth:`send_upstream`)
        self.sock = self.ctx.socket(zmq.XSUB if answers else zmq.SUB)
        self.sock.setsockopt(zmq.RCVHWM, HWM)
        self.sock.setsockopt(zmq.LINGER, 0)
        for t in topics:
            if answers:
                self.sock.send(b"\x01" + t.encode())
            else:
                self.sock.setsockopt(zmq.SUBSCRIBE, t.encode())
        self._key_checks: list[KeyCheck] = []
        self._handshakes = HandshakeWatch(self.sock, self.endpoints)  # before connecting
        try:
            for ep in self.endpoints:
                check = attach(self.sock, ep, keys, client_key)
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
        # monotonic time up to which everything sent has been read: the last moment this
        # subscriber found nothing waiting (a reader that stalls does not move it on, so
        # its messages still queued are not taken for a publisher's silence)
        self.heard_until = time.monotonic()

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
                self.heard_until = time.monotonic()
                wait = (None if deadline is None
                        else max(0, int((deadline - time.monotonic()) * 1000)))
                if not self.sock.poll(wait, zmq.POLLIN):
                    self.heard_until = time.monotonic()  # nothing came while it waited
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
            last = self._last.pop(key, None)  # re-inserted below: the newest at the end
            end = env.seq + env.count - 1
            if last is None:
                if len(self._last) >= MAX_STREAMS:
                    del self._last[next(iter(self._last))]
                    self.stats.streams_forgotten += 1
                if len(self.stats.started_at) < MAX_STARTED_AT:
                    self.stats.started_at[f"{env.topic}@{env.publisher:08x}"] = env.seq
            elif end <= last:
                self.stats.duplicates += env.count
                self._last[key] = last
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

    def count_queued(self, deadline: float) -> tuple[int, bool]:
        """Read what is queued without decoding it: the pen samples it held, and
        whether the queue was emptied before ``deadline`` (monotonic seconds)."""
        n = len(self._pending)  # the rest of a batch already taken apart
        self._pending.clear()
        while time.monotonic() < deadline:
            try:
                frames = self.sock.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return n, True
            head = wire.pen_header(frames)
            if head is None:
                continue
            publisher, seq, count = head
            key = (publisher, frames[0].decode("ascii", "replace"))
            last = self._last.get(key)
            if last is not None and seq > last + 1:  # the publisher dropped these (its HWM)
                self.stats.lost += seq - last - 1
            if last is None or seq + count - 1 > last:
                self._last[key] = seq + count - 1
                n += count if last is None else min(count, seq + count - 1 - last)
        return n, False

    def send_upstream(self, data: bytes) -> bool:
        """Send ``data`` (one frame, not starting with 0 or 1) back to every publisher
        connected to this subscriber (made with ``answers=True``): a command's sender
        picks its own answer by id.  Never blocks; ``False`` when it could not go."""
        if self.sock.type != zmq.XSUB or not data or data[0] in (0, 1):
            return False
        try:
            self.sock.send(data, zmq.NOBLOCK)
        except zmq.ZMQError:
            return False
        return True

    def close(self) -> None:
        self._handshakes.close()
        self.sock.close()
        wait_released(self.endpoints)

    def __enter__(self) -> Subscriber:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

