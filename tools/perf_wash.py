"""Where the ``cpu`` backend's wash spends its time, instruction by instruction (issue 26).

``tools/profile_wash.py`` times whole sweeps; this samples them with Linux ``perf``
(software clock, no hardware counters needed) and names numba's compiled code, which
``perf`` cannot do by itself: numba loads its cached kernels as object code without
telling ``perf``.  The symbols come from the cached objects themselves
(``station/backends/cpu/__pycache__/*.nbc``, read with ``nm``), their addresses from the
running process's JIT; they are written to ``/tmp/perf-PID.map``, which ``perf report``
reads.  Prints each kernel's share of the samples and, with ``--hot N``, the share of its
samples on 512-bit vector instructions and the N hottest instructions of the sweeps
(a scalar ``vaddss``/``vmovss`` loop or a ``vscatterqps`` in a column loop is numba's
negative-index wraparound at work: index with an unsigned column).

    .venv/bin/python tools/perf_wash.py [--size 1920x1080] [--seconds 15] [--hot 8]

Needs ``perf``, ``nm`` and ``objdump`` (binutils) and a warm numba cache (run a step
first); it compiles nothing of its own.
"""

from __future__ import annotations

import argparse
import bisect
import collections
import glob
import os
import pickle
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from station.backends.cpu import kernels as K
from station.backends.factory import create_backend
from station.bench._sim_driver import wash

CACHE = Path(K.__file__).parent / "__pycache__"


def _cached_objects() -> dict[str, bytes]:
    """Kernel name -> the ELF object numba cached for it (the first overload)."""
    out: dict[str, bytes] = {}
    for f in sorted(glob.glob(str(CACHE / "*.nbc"))):
        # our own cache files, written by numba in this checkout
        data = pickle.loads(Path(f).read_bytes())
        name = Path(f).name.split("-")[0]
        lib = data[0]
        if isinstance(lib, tuple) and len(lib) == 3 and lib[1] == "object":
            out.setdefault(name, bytes(lib[2][0]))
    return out


def _symbols(obj: bytes) -> list[tuple[str, int]]:
    """(name, size) of the functions an object defines (``nm -S``)."""
    with tempfile.NamedTemporaryFile(suffix=".o") as t:
        t.write(obj)
        t.flush()
        res = subprocess.run(["nm", "-S", "--defined-only", t.name], capture_output=True,
                             text=True, check=True)
    syms = []
    for line in res.stdout.splitlines():
        p = line.split()
        if len(p) == 4 and p[2] in "TtWw":
            syms.append((p[3], int(p[1], 16)))
    return syms


def _disassembly(obj: bytes) -> dict[tuple[str, int], str]:
    """(function, offset) -> instruction text of an object."""
    with tempfile.NamedTemporaryFile(suffix=".o") as t:
        t.write(obj)
        t.flush()
        text = subprocess.run(["objdump", "-d", "--no-show-raw-insn", "-M", "intel", t.name],
                              capture_output=True, text=True, check=True).stdout
    out: dict[tuple[str, int], str] = {}
    cur: tuple[int, str] | None = None
    for line in text.splitlines():
        m = re.match(r"^([0-9a-f]+) <(.*)>:", line)
        if m:
            cur = (int(m.group(1), 16), m.group(2))
            continue
        m = re.match(r"^\s+([0-9a-f]+):\s+(.*)$", line)
        if m and cur:
            out[(cur[1], int(m.group(1), 16) - cur[0])] = m.group(2)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--seconds", type=float, default=15.0)
    ap.add_argument("--hot", type=int, default=0, help="hottest instructions to list")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    canvas: Any = create_backend("cpu", w, h, "watercolor", 1, tiling=False)
    wash(canvas, w, h)
    for _ in range(3):
        canvas.step()
    engine = None
    for fn in vars(K).values():
        if getattr(fn, "overloads", None):
            engine = next(iter(fn.overloads.values())).library._codegen._engine
            break
    if engine is None:
        sys.exit("no compiled kernel found")
    objects = _cached_objects()
    spans: list[tuple[int, int, str, str]] = []  # address, size, kernel, symbol
    for kern, obj in objects.items():
        for name, size in _symbols(obj):
            addr = engine.get_function_address(name)
            if addr:
                spans.append((addr, size, kern, name))
    pid = os.getpid()
    perf_map = Path(f"/tmp/perf-{pid}.map")  # read by perf report; this tool resolves itself
    perf_map.write_text(
        "".join(f"{a:x} {s:x} {k}:{n}\n" for a, s, k, n in spans))
    data = tempfile.mktemp(suffix=".perf")
    stop = threading.Event()

    def stepping() -> None:
        while not stop.is_set():
            canvas.step()

    th = threading.Thread(target=stepping)
    th.start()
    time.sleep(0.5)
    subprocess.run(["perf", "record", "-q", "-e", "cpu-clock", "-F", "1000", "-p", str(pid),
                    "-o", data, "--", "sleep", str(args.seconds)], check=True,
                   capture_output=True)
    stop.set()
    th.join()
    ips = subprocess.run(["perf", "script", "-i", data, "-F", "ip"], capture_output=True,
                         text=True, check=True).stdout.split()
    os.unlink(data)
    perf_map.unlink()
    spans.sort()
    starts = [s[0] for s in spans]
    per_kernel: collections.Counter[str] = collections.Counter()
    vector: collections.Counter[str] = collections.Counter()
    hot: collections.Counter[tuple[str, str, int]] = collections.Counter()
    dis = {k: _disassembly(o) for k, o in objects.items()} if args.hot else {}
    for ip in ips:
        v = int(ip, 16)
        i = bisect.bisect_right(starts, v) - 1
        if i < 0 or v >= spans[i][0] + spans[i][1]:
            per_kernel["(not numba)"] += 1
            continue
        a, _, kern, name = spans[i]
        per_kernel[kern] += 1
        hot[(kern, name, v - a)] += 1
    total = max(len(ips), 1)
    print(f"{args.size} wash, {len(ips)} samples, load {os.getloadavg()[0]:.2f}")
    for (kern, name, off), n in hot.items():
        if "zmm" in dis.get(kern, {}).get((name, off), ""):
            vector[kern] += n
    for kern, n in per_kernel.most_common():
        zmm = f"  ({100 * vector[kern] / n:.0f} % on zmm)" if dis else ""
        print(f"  {100 * n / total:5.1f} %  {kern}{zmm}")
    for (kern, name, off), n in hot.most_common(args.hot):
        print(f"  {n:5d}  {kern}+{off:x}  {dis.get(kern, {}).get((name, off), '?')}")


if __name__ == "__main__":
    main()
