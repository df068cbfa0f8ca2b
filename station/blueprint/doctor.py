"""``station doctor``: is this machine ready to run a station, and what to fix if not.

Each check gives ``ok``, ``warn`` (works, but worth knowing) or ``fail`` with the
fix.  With a blueprint the checks are about what it uses: its devices, its
calibration files, its gallery, the bus of a station already running it.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from station import paths
from station.backends import choice as backend_choice
from station.blueprint.exposure import gallery_exposure
from station.blueprint.model import BlueprintError
from station.blueprint.plan import Plan
from station.blueprint.supervisor import running_pid
from station.bus import Publisher, Subscriber, keys_dir, load_keys, runtime_dir
from station.calibration.files import config_dir, find_for_device, read_file
from station.drivers.scan import scan
from station.errors import BusConfigError, StationError
from station.udev.generate import RULES_NAME, generate

UDEV_DIRS = (Path("/etc/udev/rules.d"), Path("/run/udev/rules.d"), Path("/lib/udev/rules.d"),
             Path("/usr/lib/udev/rules.d"))
DEFAULT_MIN_FREE = 1 << 30  # 1 GiB for the gallery and session logs
GL_TIMEOUT_S = 60.0
AUTO_TIMEOUT_S = backend_choice.CHILD_TIMEOUT_S + 60.0
"""The backend probe in a child: a first run compiles the cpu backend (minutes on a
loaded 2-core machine).  Longer than the probe's own deadline, so the probe's partial
answer (what it measured, what is pending) reaches the doctor."""

_AUTO_PROBE = """
import json
from station.backends.factory import auto_choice
c = auto_choice()
print(json.dumps(dict(c.as_dict(), cached=c.cached)))
"""

_GL_PROBE = """
import json, moderngl
ctx = moderngl.create_standalone_context(backend="egl", require=330)
print(json.dumps({"vendor": ctx.info["GL_VENDOR"], "renderer": ctx.info["GL_RENDERER"],
                  "version": ctx.version_code}))
"""


@dataclass(frozen=True)
class Check:
    """One finding: ``status`` is ok, warn or fail; ``fix`` says what to do."""

    name: str
    status: str
    detail: str
    fix: str = ""


def check_gl() -> Check:
    """An EGL context in a child process (a broken driver cannot take the doctor down)."""
    try:
        proc = subprocess.run([sys.executable, "-c", _GL_PROBE], capture_output=True,
                              text=True, timeout=GL_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return Check("gl", "fail", f"creating an EGL context took over {GL_TIMEOUT_S:g} s",
                     "check the GPU driver; meanwhile run the sim with --backend cpu")
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["unknown error"])[-1]
        return Check("gl", "fail", f"no EGL OpenGL context: {last}",
                     "install Mesa's EGL and drivers (apt install libegl1 libgl1-mesa-dri) or "
                     "the GPU vendor's driver; the sim still runs with --backend cpu")
    info = json.loads(proc.stdout.strip().splitlines()[-1])
    version = int(info["version"])
    detail = (f"EGL: {info['vendor']} / {info['renderer']}, OpenGL "
              f"{version // 100}.{version % 100 // 10}")
    if version < 430:
        return Check("gl", "warn", detail + " (the gl backend needs 4.3)",
                     "use --backend cpu, or a newer driver for the gl backend")
    if any(k in str(info["renderer"]).lower() for k in ("llvmpipe", "softpipe", "swrast")):
        return Check("gl", "warn", detail + ": software rendering on the CPU",
                     "install the GPU's driver for speed; --backend auto measures and picks the "
                     "fastest meanwhile (the backend check)")
    return Check("gl", "ok", detail)


def _describe(c: backend_choice.Choice, cached: bool) -> str:
    figures = ", ".join(
        f"{k} {'not measured yet' if k in c.pending else 'failed' if v is None else f'{v:g}'}"
        for k, v in sorted(c.steps_per_s.items()))
    gl = f"GL renderer {c.renderer!r}" if c.renderer is not None else "no GL"
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(c.measured_at))
    return (f"--backend auto = {c.backend}: steps/s on a {c.probe}: {figures}; {gl}; "
            f"{'cached, measured' if cached else 'measured just now'} {when}")


def check_backend(measure: bool) -> Check:
    """What ``--backend auto`` picks here and the figures it picked by: measured in a
    child process (a broken GL driver cannot take the doctor down) and cached, or with
    ``measure=False`` (``--no-gl``) only what the cache holds."""
    if not measure:
        cached = backend_choice.load()
        if cached is None:
            return Check("backend", "ok", "--backend auto: not measured on this machine yet "
                         "(the first --backend auto, or station doctor without --no-gl, "
                         "measures every backend for a few seconds)")
        return Check("backend", "ok", _describe(cached, True))
    try:
        proc = subprocess.run([sys.executable, "-c", _AUTO_PROBE], capture_output=True,
                              text=True, timeout=AUTO_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return Check("backend", "fail", f"measuring the backends took over "
                     f"{AUTO_TIMEOUT_S:g} s", "run the sim with --backend cpu")
    try:
        if proc.returncode != 0:
            raise ValueError((proc.stderr.strip().splitlines() or ["unknown error"])[-1])
        data = json.loads(proc.stdout.strip().splitlines()[-1])
        c = backend_choice.Choice.from_dict(data)
    except (ValueError, IndexError) as exc:
        return Check("backend", "fail", f"measuring the backends failed: {exc}",
                     "run the sim with --backend cpu")
    failed = dict(c.errors)
    detail = _describe(c, bool(data.get("cached")))
    if c.pending:
        return Check("backend", "warn", detail + "; " + "; ".join(
            f"{k}: {v}" for k, v in {**failed, **c.pending}.items()),
            "run station doctor again when the machine is quieter: it measures only what "
            "is pending (the cpu backend's compile is cached as it goes)")
    if failed:
        return Check("backend", "warn", detail + "; " + "; ".join(
            f"{k}: {v}" for k, v in failed.items()), "see the gl check")
    return Check("backend", "ok", detail)


def check_devices(plan: Plan | None) -> list[Check]:
    found = scan()
    checks = []
    for problem in found["problems"]:
        checks.append(Check("devices", "fail", problem,
                            "install the udev rules (station udev -o 70-painting-station.rules;"
                            " sudo install -m 0644 it in /etc/udev/rules.d/) and add the user "
                            "to the 'station' group"))
    real = [d for k in ("evdev", "hidraw", "hidapi", "usb") for d in found[k]
            if "problem" not in d]
    wanted = _wanted_devices(plan)
    for ident, spec, vid, pid in wanted:
        if spec is not None and spec.startswith("auto:"):
            if real:
                checks.append(Check("devices", "ok", f"{ident}: {spec}: will take "
                                    f"{real[0].get('name', '')} ({real[0]['spec']})"))
            else:
                checks.append(Check("devices", "fail", f"{ident}: {spec}: no pen tablet found",
                                    "plug the tablet in; `station devices` lists what is "
                                    "here and why a device cannot be opened"))
        elif spec is not None and not spec.startswith(("mock", "trace:", "serial-mock")):
            node = spec.split(":", 1)[1].split("?", 1)[0]
            if node.startswith("/dev/") and not os.path.exists(node):
                checks.append(Check("devices", "fail", f"{ident}: {node} does not exist",
                                    "plug the device in, or fix device= in the blueprint"))
            elif node.startswith("/dev/") and not os.access(node, os.R_OK | os.W_OK):
                checks.append(Check("devices", "fail", f"{ident}: no read/write access to "
                                    f"{node}", "install the udev rules and join the "
                                               "'station' group (then log in again)"))
            else:
                checks.append(Check("devices", "ok", f"{ident}: {spec}"))
        elif vid is not None:
            match = [d for d in real if d.get("vid") == vid.lower() and d.get("pid") ==
                     pid.lower()]  # type: ignore[union-attr]
            if match:
                checks.append(Check("devices", "ok", f"{ident}: {vid}:{pid} at "
                                    f"{match[0]['spec']}"))
            else:
                checks.append(Check("devices", "fail", f"{ident}: no device {vid}:{pid} "
                                    "found (or not readable)",
                                    "plug the tablet in; `station devices` lists what is "
                                    "here and why a device cannot be opened"))
        else:
            checks.append(Check("devices", "ok", f"{ident}: {spec} (no hardware needed)"))
    if not wanted and not found["problems"]:
        if real:
            names = ", ".join(f"{d.get('name', '')} ({d['spec']})" for d in real[:4])
            checks.append(Check("devices", "ok", f"{len(real)} pen device(s): {names}"))
        else:
            checks.append(Check("devices", "warn", "no pen tablet found",
                                "plug one in; mocks (station devices lists them) work "
                                "without"))
    return checks


def _wanted_devices(plan: Plan | None) -> list[tuple[str, str | None, str | None, str | None]]:
    if plan is None:
        return []
    out = []
    for c in plan.blueprint.components:
        if c.kind in ("driver", "haptic"):
            out.append((c.id, c.get("device"), c.get("vid"), c.get("pid")))
    return out


def check_udev(dirs: tuple[Path, ...] | None = None, needed: bool = True) -> Check:
    """The udev rules: missing is a failure where a tablet is here (or a blueprint
    names one), only a warning on a machine with none (mocks and traces need none)."""
    dirs = dirs if dirs is not None else UDEV_DIRS
    for d in dirs:
        path = d / RULES_NAME
        if path.is_file():
            try:
                text = path.read_text(encoding="utf-8")
            except OSError as exc:
                return Check("udev", "fail", f"{path}: cannot read ({exc.strerror})",
                             f"sudo chmod 0644 {path}")
            if text != generate():
                return Check("udev", "warn", f"{path}: installed, but not the rules this "
                             "version generates (new tablets missing?)",
                             f"station udev -o {RULES_NAME} && sudo install -m 0644 "
                             f"{RULES_NAME} {path}")
            return Check("udev", "ok", f"{path}: up to date")
    where = ", ".join(str(d) for d in dirs)
    if not needed:
        return Check("udev", "warn", f"no {RULES_NAME} in {where} (not needed until a "
                     "pen tablet is plugged in)",
                     f"before plugging one in: station udev -o {RULES_NAME} && sudo "
                     f"install -m 0644 {RULES_NAME} /etc/udev/rules.d/ && sudo udevadm "
                     "control --reload && sudo udevadm trigger")
    return Check("udev", "fail", f"no {RULES_NAME} in {where}",
                 f"station udev -o {RULES_NAME} && sudo install -m 0644 {RULES_NAME} "
                 f"/etc/udev/rules.d/ && sudo udevadm control --reload && sudo udevadm "
                 "trigger")


def check_calibration(plan: Plan | None) -> list[Check]:
    checks = []
    if plan is not None:
        for ident, path in plan.calibrations.items():
            try:
                read_file(path)
            except OSError as exc:
                checks.append(Check("calibration", "fail", f"{ident}: {path}: "
                                    f"{exc.strerror or exc}",
                                    "run `station calibrate` for the tablet, or fix file="))
                continue
            except BlueprintError:
                raise
            except Exception as exc:  # a malformed file: its own message names it
                checks.append(Check("calibration", "fail", f"{ident}: {exc}",
                                    "run `station calibrate` again to rewrite it"))
                continue
            checks.append(Check("calibration", "ok", f"{ident}: {path}"))
        for c in plan.blueprint.components:
            if c.kind == "driver" and c.get("vid") and c.get("calibration", "auto") == "auto" \
                    and not any(w.interface == "calibration" for w in c.requires):
                vid, pid = int(c.attrs["vid"], 16), int(c.attrs["pid"], 16)
                found = find_for_device(vid, pid)
                if found is None:
                    checks.append(Check("calibration", "fail",
                                        f"{c.id}: no calibration for {c.attrs['vid']}:"
                                        f"{c.attrs['pid']} in {config_dir()}",
                                        "run `station calibrate` with the tablet plugged in"))
                else:
                    checks.append(Check("calibration", "ok", f"{c.id}: {found}"))
    if not checks:
        files = sorted(config_dir().glob("*.json")) if config_dir().is_dir() else []
        checks.append(Check("calibration", "ok" if files else "warn",
                            f"{len(files)} calibration file(s) in {config_dir()}",
                            "" if files else "run `station calibrate` for each tablet (pens "
                                             "then map to the canvas exactly)"))
    return checks


def check_bus(plan: Plan | None) -> list[Check]:
    checks = []
    try:
        rdir = runtime_dir()
        with Publisher(f"@ipc://{rdir}/doctor-{os.getpid()}", replay=False):
            pass
        checks.append(Check("bus", "ok", f"ipc sockets can be made in {rdir} (0700)"))
    except (StationError, OSError) as exc:
        checks.append(Check("bus", "fail", f"the bus cannot be set up: {exc}",
                            "set STATION_RUNTIME_DIR to a directory of your own (0700), or "
                            "fix XDG_RUNTIME_DIR"))
    if plan is not None:
        pid = running_pid(plan.run_dir)
        if pid is None:
            checks.append(Check("bus", "ok", f"station {plan.blueprint.name!r} is not "
                                f"running ({plan.run_dir})"))
        else:
            for p in plan.processes:
                if p.status is None:
                    continue
                sub = Subscriber(p.status, topics=("status",))
                try:
                    msg = None
                    for _ in range(30):
                        msg = sub.recv(100)
                        if msg is not None:
                            break
                finally:
                    sub.close()
                if msg is None:
                    checks.append(Check("bus", "fail", f"{p.id}: no status on {p.status} in "
                                        "3 s", f"look at {plan.run_dir}/logs/{p.id}.log"))
                else:
                    checks.append(Check("bus", "ok", f"{p.id} answers on {p.status}"))
    return checks


def check_keys(plan: Plan | None) -> list[Check]:
    """The CURVE keys of each tcp ``<bus>``: the server pair ``station bus`` binds with,
    the client pair its sources and consumers connect with, at least one authorised
    client key."""
    checks: list[Check] = []
    if plan is None:
        return checks
    for c in plan.blueprint.components:
        if c.kind != "bus" or not any((c.get(a) or "").startswith("tcp://")
                                      for a in ("pub", "sub")):
            continue
        argv = plan.process(c.id).argv
        directory = Path(argv[argv.index("--keys") + 1]) if "--keys" in argv else keys_dir()
        fix = (f"station keys --dir {directory} (on the other machine: copy server.key, "
               "client.key and client.key_secret there)")
        try:
            load_keys(directory, "server")
            load_keys(directory, "client")
        except BusConfigError as exc:
            checks.append(Check("keys", "fail", f"{c.id}: {exc}", fix))
            continue
        allowed = sorted((directory / "authorized").glob("*.key"))
        if not allowed:
            checks.append(Check("keys", "fail", f"{c.id}: no authorised client key in "
                                f"{directory / 'authorized'}: every client is refused", fix))
        else:
            checks.append(Check("keys", "ok", f"{c.id}: CURVE keys in {directory}, "
                                f"{len(allowed)} authorised client key(s)"))
    return checks


def _parse_size(text: str) -> int:
    units = {"": 1, "B": 1, "K": 1 << 10, "KiB": 1 << 10, "M": 1 << 20, "MiB": 1 << 20,
             "G": 1 << 30, "GiB": 1 << 30, "T": 1 << 40, "TiB": 1 << 40}
    num = text.rstrip("KMGTiB")
    unit = text[len(num):]
    if unit not in units:
        raise ValueError(text)
    return int(float(num) * units[unit])


def check_disk(plan: Plan | None, data_dir: Path | None = None) -> list[Check]:
    targets: list[tuple[str, Path, int]] = []
    if plan is not None:
        for c in plan.blueprint.components:
            if c.kind == "gallery":
                try:
                    need = _parse_size(c.get("min-free") or "1GiB")
                except ValueError:
                    raise BlueprintError(f"min-free={c.get('min-free')!r}: a size like 1GiB",
                                         str(c.where)) from None
                targets.append((c.id, plan.galleries[c.id], need))
    if not targets:
        base = data_dir or paths.data_dir()
        targets.append(("data", base, DEFAULT_MIN_FREE))
    checks = []
    for ident, path, need in targets:
        probe = path
        while not probe.exists() and probe != probe.parent:
            probe = probe.parent
        free = shutil.disk_usage(probe).free
        detail = (f"{ident}: {free / (1 << 30):.1f} GiB free at {path} "
                  f"(needs {need / (1 << 30):.1f})")
        if free < need:
            checks.append(Check("disk", "fail", detail,
                                "free some space (old session logs in sessions/, gallery "
                                "paintings) or point the gallery elsewhere"))
        else:
            checks.append(Check("disk", "ok", detail))
    return checks


def run_checks(plan: Plan | None, gl: bool = True) -> list[Check]:
    checks: list[Check] = []
    if gl:
        checks.append(check_gl())
    checks.append(check_backend(measure=gl))
    devices = check_devices(plan)
    checks += devices
    # "no pen tablet found" and nothing named: the station runs (mocks, traces, the
    # demo) and the rules matter only once a tablet comes
    no_tablet = all(c.status == "warn" for c in devices) or all(
        "no hardware needed" in c.detail for c in devices)
    checks.append(check_udev(needed=not no_tablet))
    checks += check_calibration(plan)
    checks += check_bus(plan)
    checks += check_keys(plan)
    checks += check_disk(plan)
    if plan is not None:
        checks += [Check("gallery", "warn", line, "serve it on 127.0.0.1, or set the options "
                         "named (docs/gallery.md)")
                   for line in gallery_exposure(plan.blueprint)]
    return checks


def report(checks: list[Check]) -> str:
    lines = []
    for c in checks:
        lines.append(f"{c.status.upper():<5} {c.name}: {c.detail}")
        if c.fix and c.status != "ok":
            lines.append(f"      fix: {c.fix}")
    bad = sum(c.status == "fail" for c in checks)
    warned = sum(c.status == "warn" for c in checks)
    lines.append(f"{bad} problem(s)" if bad else "all good" if not warned else
                 f"all good: this machine can run a station ({warned} warning(s) above)")
    return "\n".join(lines) + "\n"


def as_json(checks: list[Check]) -> dict[str, object]:
    return {"ok": not any(c.status == "fail" for c in checks),
            "checks": [asdict(c) for c in checks]}
