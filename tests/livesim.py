"""Helpers for tests that run ``station sim`` and drivers as real processes."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from station.bus import Publisher, Subscriber
from station.events import PenSample, Tool


def start_sim(bus: str, *args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "station", "sim", "--bus", bus, *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def stop(proc: subprocess.Popen[str], timeout: float = 30.0) -> tuple[int, str]:
    """SIGTERM and wait; returns (exit code, stderr)."""
    if proc.poll() is None:
        proc.terminate()
    try:
        _out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        _out, err = proc.communicate()
    return proc.returncode, err


def idle(pub: Publisher, seconds: float) -> None:
    """Wait while the publisher stays alive: heartbeats, late-joiner replays."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        pub.tick()
        pub.poll_subscriptions()
        time.sleep(0.02)


def wait_subscriptions(pub: Publisher, count: int, timeout: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout
    while pub.subscriptions < count:
        if time.monotonic() > deadline:
            return False
        idle(pub, 0.05)
    return True


class Pen:
    """A scripted pen publishing on the bus with contiguous device sequence numbers."""

    def __init__(self, pub: Publisher, device: str = "pen-0") -> None:
        self.pub, self.device, self.seq, self.t = pub, device, 0, 100.0

    def sample(self, x: float, y: float, touching: bool, proximity: bool = True) -> None:
        self.seq += 1
        self.t += 0.01
        self.pub.publish_pen(PenSample(t=self.t, device=self.device, tool=Tool.PEN, x=x, y=y,
                                       pressure=0.8 if touching else 0.0, touching=touching,
                                       proximity=proximity, seq=self.seq))

    def stroke(self, y: float, n: int = 12, x0: float = 0.15, x1: float = 0.85,
               lift: bool = True, start: int = 0) -> None:
        for i in range(start, n):
            self.sample(x0 + (x1 - x0) * i / max(n - 1, 1), y, True)
            idle(self.pub, 0.01)
        if lift:
            self.sample(x1, y, False, proximity=False)
            idle(self.pub, 0.01)


def wait_for(pred: Any, timeout: float, pub: Publisher | None = None) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return True
        if pub is not None:
            idle(pub, 0.05)
        else:
            time.sleep(0.05)
    return False


def statuses(sub: Subscriber, pred: Any, timeout: float) -> dict[str, Any] | None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        msg = sub.recv(100)
        if msg is not None and msg.kind == "status" and pred(msg.value):
            return dict(msg.value)
    return None


def paint(log: Path, png: Path, backend: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "station", "paint", str(log), "-o", str(png),
                           "--backend", backend], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def pixels(png: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(png), dtype=np.int32)


def log_records(log: Path) -> list[dict[str, Any]]:
    """The log's records so far; a line the sim is still writing (no newline yet) is left
    for the next look (seen at load 10: a record cut after 136 characters)."""
    text = log.read_text()
    complete = text[: text.rfind("\n") + 1]
    lines = [ln for ln in complete.splitlines() if ln.strip()]
    return [json.loads(ln) for ln in lines[1:]]
