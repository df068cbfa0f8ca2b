"""A private Xvfb for the tests that open windows.

The server picks its own display number (``-displayfd``) and says it when it is ready to
take clients: two tests, or two test runs, starting an Xvfb at once never race for a
``:N`` the way a scan of ``/tmp/.X*-lock`` files does.
"""

from __future__ import annotations

import os
import select
import shutil
import subprocess
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import IO

import pytest

START_DEADLINE_S = 60.0  # a loaded CI machine can take a while to start a server


@contextmanager
def xvfb(width: int = 1024, height: int = 768) -> Iterator[str]:
    """``DISPLAY`` of a fresh ``Xvfb -noreset`` (``:N``), stopped on exit."""
    exe = shutil.which("Xvfb")
    if exe is None:
        pytest.skip("Xvfb is not installed (make test installs it: apt-get install xvfb)")
    # the server's output goes to a file, not a pipe: a chatty server never blocks on it
    with tempfile.TemporaryFile() as log:
        read_fd, write_fd = os.pipe()
        try:
            proc = subprocess.Popen([exe, "-displayfd", str(write_fd), "-screen", "0",
                                     f"{width}x{height}x24", "-nolisten", "tcp", "-noreset"],
                                    pass_fds=(write_fd,), stdout=subprocess.DEVNULL, stderr=log)
        finally:
            os.close(write_fd)
        try:
            number = _read_display(read_fd, proc, log)
            yield f":{number}"
        finally:
            os.close(read_fd)
            if proc.poll() is None:
                proc.terminate()
                try:
                    proc.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()


def _read_display(fd: int, proc: subprocess.Popen[bytes], log: IO[bytes]) -> int:
    """The number Xvfb writes to ``-displayfd`` once it listens."""
    deadline = time.monotonic() + START_DEADLINE_S
    got = b""
    while not got.endswith(b"\n"):
        left = deadline - time.monotonic()
        if left <= 0:
            proc.kill()
            pytest.fail(f"Xvfb did not start in {START_DEADLINE_S:g} s")
        ready, _, _ = select.select([fd], [], [], min(left, 0.5))
        if ready:
            chunk = os.read(fd, 64)
            if not chunk:  # the server closed the pipe without a number: it failed
                break
            got += chunk
    if not got.strip().isdigit():
        proc.kill()
        proc.wait()
        log.seek(0)
        pytest.fail(f"Xvfb did not start (exit {proc.returncode}): "
                    f"{log.read().decode(errors='replace')[-500:]}")
    return int(got)
