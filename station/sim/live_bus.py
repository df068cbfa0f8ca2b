"""``station sim`` on the bus: :class:`LiveSim` is :class:`~station.sim.live.LiveCore`
subscribed to ``pen.*``, ``hb.*`` and ``cmd`` (and a command endpoint of its own, for
``station send``), publishing its status on ``status`` twice a second and whenever a
device falls silent (see :mod:`station.sim.live`)."""

from __future__ import annotations

import logging
import os
import signal
import time
from types import FrameType
from typing import Any

from station.bus import Publisher, Subscriber
from station.sim.live import LiveCore
from station.sim.live_config import (
    DEFAULT_CMD_ENDPOINT,
    DRAIN_MAX,
    STATUS_EVERY_S,
    UNREAD_COUNT_S,
    LiveConfig,
    default_status_endpoint,
)
from station.wire import HapticForce

log = logging.getLogger("station.sim.live")


class LiveSim(LiveCore):
    """The running simulation process: :class:`LiveCore` on the bus."""

    def __init__(self, cfg: LiveConfig) -> None:
        # The bus first: an endpoint in use ends the run before any file is made.
        endpoints = [cfg.bus]
        cmd_ep = cfg.cmd or "@" + DEFAULT_CMD_ENDPOINT
        cmd_ep = cmd_ep if cmd_ep in ("none", "") or cmd_ep[0] in "@>" else "@" + cmd_ep
        tcp_cmd = cmd_ep.lstrip("@>").startswith("tcp://")
        if cmd_ep != "none" and not tcp_cmd:
            endpoints.append(cmd_ep)
        self.sub = Subscriber(endpoints, topics=("pen.", "cmd", "hb."),  # type: ignore[arg-type]
                              keys=cfg.keys, client_key=cfg.client_key)
        # a tcp command endpoint answers over its own connections (station.answer: "peer")
        self.cmd_sub: Subscriber | None = None
        if tcp_cmd:
            try:
                self.cmd_sub = Subscriber(cmd_ep, topics=("cmd",), keys=cfg.keys,
                                          client_key=cfg.client_key, answers=True)
            except BaseException:
                self.sub.close()
                raise
        status_ep = cfg.status or default_status_endpoint(cfg.bus)
        try:
            self.pub = None if status_ep == "none" else Publisher(
                status_ep, keys=cfg.keys, client_key=cfg.client_key)
            super().__init__(cfg)
        except BaseException:
            self.sub.close()
            if self.cmd_sub is not None:
                self.cmd_sub.close()
            pub = getattr(self, "pub", None)
            if pub is not None:
                pub.close()
            raise
        pub = self.pub
        if pub is not None:  # a haptic driver subscribes to haptic.<device>
            self.haptics.wanted = lambda name: pub.wants(f"haptic.{name}")
        self._next_status = 0.0
        self._fps_mark = (time.monotonic(), self.player.counters.steps)
        self.fps = 0.0

    def _count_unread(self) -> None:
        """Count the pen samples still queued when the sim stops (a flood leaves up to
        the queue's HWM): read, not painted, so none goes uncounted; at most
        :data:`UNREAD_COUNT_S` seconds of reading, then what is left is said as such."""
        n, emptied = self.sub.count_queued(time.monotonic() + UNREAD_COUNT_S)
        self.counters.unread_at_stop += n
        if not emptied:
            log.warning("stopping: %d queued bus samples counted, more not read",
                        self.counters.unread_at_stop)

    def _drain_commands(self, sub: Subscriber) -> None:
        """What came on the tcp command endpoint, answered back over it."""
        self.answerer.upstream = sub.send_upstream
        try:
            for _ in range(DRAIN_MAX):
                msg = sub.recv(0)
                if msg is None or self.stop_requested:
                    return
                self.handle(msg.kind, msg.value, msg.topic, msg.replay)
        finally:
            self.answerer.upstream = None

    def drain(self, timeout_ms: int) -> None:
        if self.cmd_sub is not None:
            self._drain_commands(self.cmd_sub)
        msg = self.sub.recv(timeout_ms)
        n = 0
        while msg is not None:
            self.handle(msg.kind, msg.value, msg.topic, msg.replay)
            n += 1
            if n >= DRAIN_MAX or self.stop_requested:
                return
            msg = self.sub.recv(0)

    def on_wait_step(self) -> None:
        self.maybe_publish_status()

    # -- status --------------------------------------------------------------
    def status(self) -> dict[str, Any]:
        p = self.player
        now = time.monotonic()
        mark_t, mark_steps = self._fps_mark
        if now - mark_t >= 0.25:
            self.fps = (p.counters.steps - mark_steps) / (now - mark_t)
            self._fps_mark = (now, p.counters.steps)
        st = {"process": "sim", "pid": os.getpid(), **super().status(), "fps": self.fps,
              "bus": self.sub.stats.as_dict(), "haptic": self.haptics.as_dict()}
        # samples lost on the bus, and those sent while no sim listened (recovery)
        st["lost_samples"] = self.sub.stats.lost + self.counters.missed_while_down
        if self.cmd_sub is not None:  # the tcp command endpoint: a socket of its own
            st["cmd_endpoint"] = self.cmd_sub.stats.as_dict()
        return st

    def publish_haptic(self, device: str, force: HapticForce) -> None:
        if self.pub is not None:
            self.pub.publish_haptic(device, force)

    def maybe_publish_status(self) -> None:
        """Publish the status when the last one is :data:`STATUS_EVERY_S` old."""
        now = time.monotonic()
        if now >= self._next_status:
            self._next_status = now + STATUS_EVERY_S
            self.publish_status()

    def publish_status(self, final: bool = False) -> None:
        if self.pub is None:
            return
        st = self.status()
        st["state"] = "stopped" if final else "running"
        try:
            self.pub.publish_status(st)
        except Exception as exc:  # status is best effort; painting goes on
            log.warning("cannot publish status: %s", exc)

    # -- main loop -----------------------------------------------------------
    def run(self) -> dict[str, Any]:
        """Run until stopped; returns the final status."""
        end = None if self.cfg.duration is None else self.now() + self.cfg.duration
        try:
            while not self.stop_requested:
                if end is not None and self.now() >= end:
                    break
                if self.tick():
                    self.drain(0)
                else:
                    wait = min(self.seconds_to_next_step(), 0.1)
                    self.drain(max(0, int(wait * 1000) + 1))
                self.check_devices()
                if self.newly_silent:
                    self.newly_silent.clear()
                    self.publish_status()  # name a silent device at once
                self.maybe_publish_status()
        finally:
            final = self.shutdown()
        return final

    def shutdown(self) -> dict[str, Any]:
        """Finish (see :meth:`LiveCore.finish`), publish the final status, close."""
        self.finish()
        self._count_unread()
        final = self.status()
        self.publish_status(final=True)
        self.sub.close()
        if self.cmd_sub is not None:
            self.cmd_sub.close()
        if self.pub is not None:
            self.pub.close()
        return final

    def install_signal_handlers(self) -> None:
        def on_signal(signum: int, frame: FrameType | None) -> None:
            self.stop_requested = True

        signal.signal(signal.SIGTERM, on_signal)
        signal.signal(signal.SIGINT, on_signal)
