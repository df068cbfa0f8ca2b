"""Helpers of the kiosk tests: Xvfb (xvfb_server), a bus proxy, the kiosk process, a pen."""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from xvfb_server import xvfb as xvfb  # the kiosk tests' Xvfb, from here as before

from station.bus import Publisher, Subscriber
from station.events import Command, PenSample, Tool

SCREEN = (1024, 768)


def station(*argv: str, display: str | None = None, **kw: Any) -> subprocess.Popen[str]:
    env = dict(os.environ)
    if display:
        env["DISPLAY"] = display
    return subprocess.Popen([sys.executable, "-m", "station", *argv], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


class Kiosk:
    """A ``station kiosk`` process on a private bus proxy, watched through its status."""

    def __init__(self, display: str, tmp: Path, *extra: str) -> None:
        self.tmp = tmp
        self.gallery = tmp / "gallery"
        self.shots = tmp / "shots"
        self.bus = station("bus")
        time.sleep(0.3)
        self.status_sub = Subscriber("ipc:sub", topics=("status",))
        self.pub = Publisher(">ipc:pub")
        self.proc = station("kiosk", "--windowed", "--bus", "ipc:sub", "--gallery",
                            str(self.gallery), "--serve", "127.0.0.1:0", "--base-url",
                            "http://kiosk.test:8080", "--screenshot-dir", str(self.shots),
                            "--no-vsync", *extra, display=display)
        self.last: dict[str, Any] = {}
        self.t = 0.0
        self.wait(lambda s: s.get("frames", 0) > 2, 90, "the kiosk did not start")

    def wait(self, cond: Callable[[dict[str, Any]], bool], timeout: float = 20,
             what: str = "condition") -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise AssertionError(f"kiosk exited {self.proc.returncode}: "
                                     f"{self.proc.stderr.read() if self.proc.stderr else ''}")
            m = self.status_sub.recv(100)
            if m is not None and isinstance(m.value, dict) and m.value.get("process") == "kiosk":
                self.last = m.value
                if cond(m.value):
                    return m.value
        raise AssertionError(f"timed out waiting for {what}; last status {self.last}")

    def cmd(self, command: str, **args: Any) -> None:
        self.pub.publish_cmd(Command(t=0.0, cmd=command, args=args))

    def screenshot(self, name: str) -> Path:
        path = self.shots / f"{name}.png"
        path.unlink(missing_ok=True)
        self.cmd("screenshot", name=name)
        deadline = time.monotonic() + 20
        while not path.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.2)  # written by PIL in one go; let it finish
        assert path.exists(), "no screenshot"
        return path

    def pen(self, x: float, y: float, touching: bool = False, proximity: bool = True,
            pressure: float = 0.6, tool: Tool = Tool.PEN) -> None:
        """One sample of a scripted pen at window pixel (x, y)."""
        self.t += 0.005
        self.pub.publish_pen(PenSample(
            t=self.t, device="testpen", tool=tool, x=x / SCREEN[0], y=y / SCREEN[1],
            pressure=pressure if touching else 0.0, proximity=proximity, touching=touching,
            t_mono=time.monotonic()))

    def tap(self, rect: list[float] | tuple[float, ...], pause: float = 0.15) -> None:
        x, y = (rect[0] + rect[2]) / 2, (rect[1] + rect[3]) / 2
        self.pen(x, y)
        time.sleep(pause)
        self.pen(x, y, touching=True)
        time.sleep(pause)
        self.pen(x, y, touching=False)
        time.sleep(pause)

    def stop(self, send: bool = False) -> tuple[int, str]:
        """Stop the kiosk: a ``stop`` on the bus, or ``station send stop`` (its own
        command endpoint, as an operator would)."""
        if send:
            sender = station("send", "stop", "--to", "kiosk")
            _, err = sender.communicate(timeout=60)
            assert sender.returncode == 0, err
        else:
            self.cmd("stop")
        try:
            _, err = self.proc.communicate(timeout=60)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
            self.bus.terminate()
            self.bus.wait(10)
            self.status_sub.close()
            self.pub.close()
        return self.proc.returncode, err


def own_process(module_file: str, flag: str, timeout: float = 600
                ) -> Callable[[Callable[..., None]], Callable[..., None]]:
    """A decorator for the window tests of ``module_file``: all of them run once in one
    fresh pytest process (``flag`` set in its environment; there the test itself runs),
    and each test here reads its own outcome from that process's report.  A fresh
    process: numba's threading layer, GL contexts and compiled kernels start from
    nothing, whatever the tests before did."""
    @functools.cache
    def child_run() -> str:
        proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-rA", "-p",
                               "no:cacheprovider", module_file], env={**os.environ, flag: "1"},
                              capture_output=True, text=True, timeout=timeout)
        return proc.stdout + proc.stderr

    def decorate(test: Callable[..., None]) -> Callable[..., None]:
        @functools.wraps(test)
        def run(*args: Any, **kw: Any) -> None:
            if os.environ.get(flag):
                test(*args, **kw)
                return
            node = f"{test.__name__}" + (f"[{kw['mode']}]" if "mode" in kw else "")
            out = child_run()
            lines = out.splitlines()
            if any(ln.startswith("PASSED ") and ln.endswith("::" + node) for ln in lines):
                return
            if any(ln.startswith(("FAILED ", "ERROR ")) and "::" + node in ln for ln in lines):
                pytest.fail(f"{node} failed in its process:\n{out[-4000:]}")
            pytest.skip(f"{node} did not run in its process: {lines[-1] if lines else ''}")
        return run
    return decorate


def child_display(flag: str) -> Iterator[str]:
    """The display of :func:`own_process`'s child (a private Xvfb); ``""`` in the parent,
    whose test only reads the child's outcome."""
    if not os.environ.get(flag):
        yield ""
        return
    with xvfb() as d:
        yield d
