"""Answers to ``station send``: the process that takes a command says what it did.

A command on the bus may carry an optional ``reply`` object next to ``t``/``cmd``/
``args`` (wire format v1 unchanged: a process that does not know the key ignores
it, as it ignores any unknown key of a cmd body)::

    {"t": 0, "cmd": "brush", "args": {"size": 12},
     "reply": {"to": "ipc:///run/user/1000/station/reply-4242-9f3a", "id": "9f3a",
               "expect": "sim"}}

``to`` is an ``ipc://`` socket the sender binds in the station's runtime
directory; the process connects a PUSH socket there and sends one JSON object::

    {"id": "9f3a", "ok": true, "process": "sim", "pid": 1234,
     "session": "session-20261127-0512", "cmd": "brush", "did": "brush set (size 12)"}

or ``"ok": false`` with ``"error"`` saying why (an unknown key, a value out of
range, a command this process does not run, or ``expect`` naming another kind
of process).  A ``to`` outside the runtime directory is never connected: a
command cannot make a process reach out to a place the sender chose.

Over tcp (CURVE, the bus's keys) the sender cannot bind a socket the process
may reach, so ``to`` is ``"peer"``: the process answers over the connection the
command came on.  Its tcp command endpoint is an XSUB socket
(:class:`station.bus.Subscriber` with ``answers=True``), which can send back to
the publishers connected to it; the answer (the same JSON object, one frame)
goes to every sender connected at that moment, each an authorised CURVE client,
and each ``station send`` keeps the answer with its own id.  A ``"peer"``
request that arrives any other way is not answered (counted in ``failed``).
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zmq

log = logging.getLogger(__name__)

MAX_ID = 64
PEER = "peer"  # answer over the connection the command came on (tcp command endpoints)
PROCESS_KINDS = ("sim", "kiosk")


@dataclass(frozen=True)
class ReplyRequest:
    """Where and how to answer one command.

    Attributes:
        to: the sender's ``ipc://`` reply socket (inside the runtime directory).
        id: the sender's tag for this command (echoed in the answer), ≤ 64 characters.
        expect: the kind of process the sender meant (``sim``/``kiosk``) or ``None``.
    """

    to: str
    id: str
    expect: str | None = None

    def as_record(self) -> dict[str, object]:
        rec: dict[str, object] = {"to": self.to, "id": self.id}
        if self.expect is not None:
            rec["expect"] = self.expect
        return rec


def parse_request(obj: object, runtime: Path) -> ReplyRequest | None:
    """A cmd body's ``reply`` object → :class:`ReplyRequest`, or ``None`` when it is
    absent or unusable (logged: a bad reply request never stops the command)."""
    if obj is None:
        return None
    if not isinstance(obj, dict):
        log.warning("ignoring a command's reply request: not an object")
        return None
    to, rid, expect = obj.get("to"), obj.get("id"), obj.get("expect")
    if not isinstance(rid, str) or not 0 < len(rid) <= MAX_ID:
        log.warning("ignoring a command's reply request: bad id")
        return None
    if expect is not None and expect not in PROCESS_KINDS:
        expect = None
    if to == PEER:
        return ReplyRequest(to=PEER, id=rid, expect=expect)
    if not isinstance(to, str) or not to.startswith("ipc://"):
        log.warning("ignoring a command's reply request: %r is not an ipc:// endpoint", to)
        return None
    path = Path(to[len("ipc://"):])
    try:
        inside = path.parent.resolve() == runtime.resolve() and path.name.startswith("reply-")
    except OSError:
        inside = False
    if not inside:
        log.warning("ignoring a command's reply request: %s is outside %s", path, runtime)
        return None
    return ReplyRequest(to=to, id=rid, expect=expect)


class Answerer:
    """Sends answers; one per process (a ZeroMQ context of its own, no state kept)."""

    def __init__(self, process: str) -> None:
        self.process = process
        self.sent = 0
        self.failed = 0
        self._ctx: zmq.Context[zmq.Socket[bytes]] | None = None
        # set by the loop while it handles what came on a tcp command endpoint: how a
        # "peer" answer goes back (Subscriber.send_upstream)
        self.upstream: Callable[[bytes], bool] | None = None

    def answer(self, req: ReplyRequest, cmd: str, ok: bool, text: str, session: str) -> None:
        body = {"id": req.id, "ok": ok, "process": self.process, "pid": os.getpid(),
                "session": session, "cmd": cmd, ("did" if ok else "error"): text}
        if req.to == PEER:
            if self.upstream is not None and self.upstream(json.dumps(body).encode()):
                self.sent += 1
            else:
                self.failed += 1
                log.warning("cannot answer %s: it did not come over a tcp command endpoint",
                            cmd)
            return
        if self._ctx is None:
            self._ctx = zmq.Context()
        sock = self._ctx.socket(zmq.PUSH)
        try:
            # never block the painting loop: a sender that went away loses its answer
            sock.setsockopt(zmq.SNDTIMEO, 0)
            sock.setsockopt(zmq.LINGER, 500)
            sock.setsockopt(zmq.IMMEDIATE, 0)
            sock.connect(req.to)
            sock.send(json.dumps(body).encode(), zmq.NOBLOCK)
            self.sent += 1
        except zmq.ZMQError as exc:
            self.failed += 1
            log.warning("cannot answer %s on %s: %s", cmd, req.to, exc)
        finally:
            sock.close()

    def close(self) -> None:
        if self._ctx is not None:
            self._ctx.term()
            self._ctx = None


class ReadKeys(dict[str, Any]):
    """A command's ``args`` that remembers which keys its handler looked at, so the
    keys nothing read can be named (``sizee=3`` is refused, not silently ignored).

    Iterating over the keys counts as reading them all: a handler that walks its
    arguments validates each one itself."""

    def __init__(self, args: Mapping[str, object]) -> None:
        super().__init__(args)
        self.read: set[str] = set()

    def __getitem__(self, key: str) -> Any:
        self.read.add(key)
        return super().__getitem__(key)

    def get(self, key: str, default: object = None) -> Any:
        self.read.add(key)
        return super().get(key, default)

    def __contains__(self, key: object) -> bool:
        if isinstance(key, str):
            self.read.add(key)
        return super().__contains__(key)

    def __iter__(self) -> Iterator[str]:
        self.read.update(super().keys())
        return super().__iter__()

    def keys(self) -> Any:
        self.read.update(super().keys())
        return super().keys()

    def items(self) -> Any:
        self.read.update(super().keys())
        return super().items()

    def unread(self) -> list[str]:
        return sorted(k for k in dict.keys(self) if k not in self.read)
