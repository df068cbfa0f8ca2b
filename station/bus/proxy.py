"""``station bus``: the many-to-many proxy between publishers and subscribers."""

from __future__ import annotations

from pathlib import Path

import zmq

from station import sdnotify
from station.bus.endpoints import resolve_endpoint
from station.bus.keys import refused_count
from station.bus.sockets import HWM, attach
from station.stopsignal import StopFlag


def run_proxy(
    pub_side: str,
    sub_side: str,
    keys: Path | None = None,
    context: zmq.Context[zmq.Socket[bytes]] | None = None,
    stop: StopFlag | None = None,
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
    checks = [c for c in (attach(frontend, resolve_endpoint(pub_side, True), keys),
                          attach(backend, resolve_endpoint(sub_side, True), keys))
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
    return refused_count(list({id(c): c for c in checks}.values()))
