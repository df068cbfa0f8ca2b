"""systemd units from a blueprint: one supervisor unit (``station run``), or one unit per
component (``station run --component ID``) tied together by a target.

Every unit runs as a dedicated user in the ``station`` group (the group the udev
rules give the tablets), in a private runtime directory (the bus's ipc sockets)
and state directory (relative outputs: session logs, PNGs, the gallery), with the
sandboxing systemd offers: ``ProtectSystem=strict``, ``ProtectHome``,
``PrivateTmp``, ``NoNewPrivileges``, no capabilities, a system-call filter, the
address families the station uses, and ``DevicePolicy=closed`` with a
``DeviceAllow=`` list of exactly the device nodes (or classes) the blueprint opens;
``systemd-analyze security`` rates every unit at most 4.0 (see :data:`HARDENING`).

Units are ``Type=notify`` with ``WatchdogSec=``: the supervisor (and, per
component, each component) says READY=1 once it runs and feeds the watchdog
from its own loop (:mod:`station.sdnotify`), so a hung process is restarted.

Every string a unit carries is checked or escaped (:func:`unit_value`,
:func:`exec_word`): a file name with a newline cannot add a line to a unit.
Outputs outside the state directory widen the sandbox (``ReadWritePaths=``) only
under the station's data directories (:data:`DATA_ROOTS`), after normalising
the path (``..`` cannot climb out of a prefix).
"""

from __future__ import annotations

import os
import re
import shutil
import sys
from pathlib import Path, PurePosixPath

from station.blueprint.model import Blueprint, BlueprintError, SupervisorError
from station.blueprint.plan import Plan, Process, resolve

GROUP = "station"
DEFAULT_USER = "station"
RESTART_SEC = {"no": None, "on-failure": "on-failure", "always": "always"}
WATCHDOG_S = 30  # a process whose loop has not fed the watchdog this long is restarted
# Where a blueprint's outputs may widen the sandbox: a directory of the station's own
# (a path component starting with "station") under these roots.  Anything else, e.g.
# /etc/cron.d, would be handed to the service read-write.
DATA_ROOTS = ("/var/lib", "/var/log", "/var/cache", "/srv", "/mnt", "/media")
_USER_RE = re.compile(r"^[a-z_][a-z0-9_-]{0,31}$")
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")
_PLAIN_WORD = re.compile(r"^[A-Za-z0-9_@%+=:,./-]+$")
# What `systemd-analyze security` weighs, minus what the station needs: numba's JIT
# writes executable memory (no MemoryDenyWriteExecute), the tablets and the GPU are
# devices (PrivateDevices only where none is opened), the bus and the gallery may use
# the network (PrivateNetwork only where no tcp endpoint is bound or reached).
HARDENING = (
    "CapabilityBoundingSet=",
    "AmbientCapabilities=",
    "ProtectClock=yes",
    "ProtectKernelLogs=yes",
    "ProtectHostname=yes",
    # not ProcSubset=pid: numba and the memory checks read /proc/meminfo, /proc/cpuinfo
    "ProtectProc=invisible",
    "PrivateMounts=yes",
    "KeyringMode=private",
    "RemoveIPC=yes",
    "RestrictRealtime=yes",
    "SystemCallArchitectures=native",
    "SystemCallFilter=@system-service",
    "SystemCallFilter=~@privileged @mount @swap @reboot @raw-io @module @debug @obsolete "
    "@cpu-emulation @clock",
    "SystemCallErrorNumber=EPERM",
    "RestrictAddressFamilies=AF_UNIX AF_INET AF_INET6 AF_NETLINK",
)


def unit_value(text: str, what: str) -> str:
    """``text`` as a value in a unit file: refused (one line saying what) if it holds
    a control character, which would end the line and start another; ``%`` escaped
    (systemd's specifiers)."""
    if not isinstance(text, str) or any(ord(ch) < 0x20 or ord(ch) == 0x7f for ch in text):
        raise BlueprintError(f"{what} {str(text)[:80]!r} holds a control character "
                             "(a newline would add lines to the unit)")
    return text.replace("%", "%%")


def exec_word(arg: str, what: str = "an argument") -> str:
    """One word of an ``ExecStart=`` line: plain when it is, else double-quoted with
    systemd's C escapes; ``%`` and ``$`` escaped (specifiers, environment)."""
    unit_value(arg, what)
    if arg and _PLAIN_WORD.match(arg):
        return arg.replace("%", "%%").replace("$", "$$")
    esc = (arg.replace("\\", "\\\\").replace('"', '\\"').replace("%", "%%")
           .replace("$", "$$"))
    return f'"{esc}"'


def _unit_path(path: str, what: str) -> str:
    """An absolute path for a unit's path settings: normalised, no spaces or quotes
    (systemd splits these settings at whitespace)."""
    norm = os.path.normpath(path)
    if not norm.startswith("/") or any(ch.isspace() or ch in "\"'" for ch in norm):
        raise BlueprintError(f"{what} {path[:80]!r} must be an absolute path without "
                             "spaces or quotes")
    return unit_value(norm, what)


def _in_data_dir(path: PurePosixPath) -> bool:
    for root in DATA_ROOTS:
        r = PurePosixPath(root)
        if path.is_relative_to(r) and path != r:
            first = path.relative_to(r).parts[0]
            if first.startswith("station"):
                return True
    return False


def _station_exe(station: str | None) -> list[str]:
    if station:
        return [station]
    exe = shutil.which("station")
    if exe:
        return [str(Path(exe).absolute())]
    return [sys.executable, "-m", "station"]


def _quote(args: list[str]) -> str:
    """systemd's ExecStart= words (see :func:`exec_word`)."""
    return " ".join(exec_word(a) for a in args)


def _device_lines(procs: list[Process]) -> list[str]:
    devices: list[str] = []
    for p in procs:
        for d in p.devices:
            if d == "/dev/dri":
                d = "char-drm"
            elif not re.match(r"^char-[a-z0-9_-]+$", d):
                d = _unit_path(d, "device")
            if d not in devices:
                devices.append(d)
    lines = ["DevicePolicy=closed"]
    lines += [f"DeviceAllow={d} rw" for d in devices]
    if not devices:
        lines.append("PrivateDevices=yes")
    return lines


def _writable(plan: Plan, procs: list[Process]) -> list[str]:
    """The directories outside the state directory the outputs need (normalised
    first); one outside :data:`DATA_ROOTS` is refused."""
    work = PurePosixPath(os.path.normpath(plan.workdir))
    rw: set[str] = set()
    for p in procs:
        for o in p.outputs:
            out = PurePosixPath(os.path.normpath(o))
            if out.is_relative_to(work):
                continue
            d = out if p.kind == "kiosk" else out.parent
            if not _in_data_dir(d):
                raise BlueprintError(
                    f"{p.id}: output {str(o)[:120]!r} is outside the station's data "
                    f"directories: under systemd it would open {d} to the service; "
                    f"write it under the state directory (a relative path) or under "
                    f"{', '.join(r + '/station…' for r in DATA_ROOTS)}")
            rw.add(_unit_path(str(d), "output directory"))
    return sorted(rw)


def _networked(procs: list[Process], plan: Plan) -> bool:
    """Whether these processes bind or reach a tcp endpoint or serve a web page."""
    text = " ".join(a for p in procs for a in p.argv)
    return "tcp://" in text or any(p.kind == "kiosk" for p in procs) or any(
        c.kind == "bus" and any((c.get(k) or "").startswith("tcp://") for k in ("pub", "sub"))
        for c in plan.blueprint.components)


def _sandbox(plan: Plan, procs: list[Process], runtime: str, state: str) -> list[str]:
    rw = _writable(plan, procs)
    lines = [
        f"RuntimeDirectory={runtime}",
        "RuntimeDirectoryMode=0700",
        f"StateDirectory={state}",
        "StateDirectoryMode=0750",
        f"WorkingDirectory=%S/{state}",
        f"Environment=STATION_RUNTIME_DIR=%t/{runtime} STATION_DATA_DIR=%S/{state}",
        "NoNewPrivileges=yes",
        "ProtectSystem=strict",
        "ProtectHome=yes",
        "PrivateTmp=yes",
        "ProtectKernelTunables=yes",
        "ProtectKernelModules=yes",
        "ProtectControlGroups=yes",
        "RestrictNamespaces=yes",
        "RestrictSUIDSGID=yes",
        "LockPersonality=yes",
        "UMask=0077",
        *HARDENING,
    ]
    if not _networked(procs, plan):
        lines.append("PrivateNetwork=yes")
    lines += [f"ReadWritePaths={p}" for p in rw]
    lines += _device_lines(procs)
    return lines


def _check_keys(bp: Blueprint) -> None:
    """A tcp ``<bus>`` needs ``keys=`` outside the home directories: the units run with
    ``ProtectHome=yes``, which hides the default ``~/.config/station/keys``."""
    for c in bp.components:
        if c.kind != "bus":
            continue
        tcp = [e for e in (c.get("pub"), c.get("sub")) if e and e.startswith("tcp://")]
        if not tcp:
            continue
        keys = c.get("keys")
        if not keys:
            raise BlueprintError("a tcp <bus> under systemd needs keys=DIR (ProtectHome=yes "
                                 "hides ~/.config/station/keys); keys=\"keys\" is the keys "
                                 "directory beside the installed blueprint", str(c.where))
        if keys.startswith(("/home/", "/root/", "/run/user/", "~")):
            raise BlueprintError(f"keys={keys!r} is hidden from the units (ProtectHome=yes); "
                                 "put the keys beside the installed blueprint", str(c.where))


def units(bp: Blueprint, per_component: bool = False, install_path: str | None = None,
          user: str | None = None, station: str | None = None,
          overrides: list[str] | None = None) -> dict[str, str]:
    """File name → unit text."""
    name = bp.name
    if not _NAME_RE.match(name or ""):
        raise BlueprintError(f"blueprint name {str(name)[:80]!r} cannot name a unit "
                             "(letters, digits, _ . -)")
    runtime = state = f"station-{name}"
    install = _unit_path(install_path or f"/etc/station/{name}.xml", "--install-path")
    # Paths as they will be on the target: the runtime and state directories.
    plan = resolve(bp, Path(f"/run/{runtime}"), Path(f"/var/lib/{state}"), stamp="")
    _check_keys(bp)
    exe = " ".join(exec_word(w, "the station command") for w in _station_exe(station))
    sets = [a for o in overrides or [] for a in ("--set", o)]
    who = user or bp.user or DEFAULT_USER
    if not _USER_RE.match(who):
        raise BlueprintError(f"user {who[:80]!r} is not a user name ([a-z_][a-z0-9_-]*)")
    source = unit_value(str(bp.file), "the blueprint's file name")
    head = [f"# Generated by `station blueprint systemd` from {source}.",
            f"# Install the blueprint as {install}; the user {who!r} must exist and be in the",
            f"# {GROUP!r} group (the udev rules give the tablets to that group)."]
    graphical = any(p.kind == "kiosk" for p in plan.processes)
    wanted = "graphical.target" if graphical else "multi-user.target"
    ident = [f"User={who}", f"Group={GROUP}", f"SupplementaryGroups={GROUP}"]
    if graphical:
        ident[-1] += " video render"
        ident += [
            "# The kiosk's window needs a display.  X11: the X server's display and a",
            "# cookie the station user can read; ProtectHome hides ~/.Xauthority, so copy it",
            f"# into the state directory (xauth extract /var/lib/{state}/.Xauthority :0) and",
            "# make the X socket directory visible through PrivateTmp.",
            "# Wayland: run the station inside a kiosk compositor instead, in a drop-in:",
            "#   [Service]",
            "#   ExecStart=",
            "#   ExecStart=/usr/bin/cage -s -- <this unit's ExecStart command>",
            "#   Environment=XDG_RUNTIME_DIR=%t/" + runtime + " WLR_LIBINPUT_NO_DEVICES=1",
            "#   TTYPath=/dev/tty7 (cage takes the seat: give the user a logind session)",
            "Environment=DISPLAY=:0",
            f"Environment=XAUTHORITY=%S/{state}/.Xauthority",
            "BindReadOnlyPaths=-/tmp/.X11-unix",
        ]
    out: dict[str, str] = {}
    if not per_component:
        text = [
            *head,
            "[Unit]",
            f"Description=Painting station {name} (blueprint, supervised)",
            "After=network.target",
            "",
            "[Service]",
            # the supervisor says READY=1 once every component is up and feeds the
            # watchdog from its loop (station.sdnotify); its children do not notify
            "Type=notify",
            "NotifyAccess=main",
            f"WatchdogSec={WATCHDOG_S}s",
            "TimeoutStartSec=300",  # a first start compiles the numba kernels
            f"ExecStart={exe} run {_quote([install, *sets])} --run-dir %t/{runtime} "
            f"--workdir %S/{state}",
            *ident,
            "Restart=on-failure",
            "RestartSec=2s",
            "RestartPreventExitStatus=2",
            # The supervisor stops its children itself, in reverse order, saving first:
            # only it gets SIGTERM; stragglers get SIGKILL after the timeout.
            "KillMode=mixed",
            "TimeoutStopSec=120",
            *_sandbox(plan, plan.processes, runtime, state),
            "",
            "[Install]",
            f"WantedBy={wanted}",
        ]
        out[f"station-{name}.service"] = "\n".join(text) + "\n"
        return out
    names = {p.id: f"station-{name}-{p.id}.service" for p in plan.processes}
    target = f"station-{name}.target"
    for i, p in enumerate(plan.processes):
        before = [names[q.id] for q in plan.processes[:i]]  # start order: everything earlier
        restart = p.restart if p.restart != "no" else "no"
        text = [
            *head,
            "[Unit]",
            f"Description=Painting station {name}: {p.id} ({p.kind})",
            f"PartOf={target}",
            *([f"After={' '.join(before)}", f"Wants={' '.join(before)}"] if before else []),
            "",
            "[Service]",
            # `run --component` execs the component, which says READY=1 with its first
            # status or heartbeat and feeds the watchdog from its loop
            "Type=notify",
            "NotifyAccess=main",
            f"WatchdogSec={WATCHDOG_S}s",
            "TimeoutStartSec=300",  # a first start compiles the numba kernels
            f"ExecStart={exe} run {_quote([install, *sets])} --component {p.id} "
            f"--run-dir %t/{runtime} --workdir %S/{state}",
            *ident,
            f"Restart={restart}",
            f"RestartSec={max(p.restart_delay_s, 0.1):g}s",
            "RestartPreventExitStatus=2",
            "TimeoutStopSec=60",
            # Units of one station share the runtime directory: keep it while any runs.
            "RuntimeDirectoryPreserve=yes",
            *_sandbox(plan, [p], runtime, state),
            "",
            "[Install]",
            f"WantedBy={target}",
        ]
        out[names[p.id]] = "\n".join(text) + "\n"
    out[target] = "\n".join([
        *head,
        "[Unit]",
        f"Description=Painting station {name} (one unit per component)",
        f"Wants={' '.join(names.values())}",
        "",
        "[Install]",
        f"WantedBy={wanted}",
    ]) + "\n"
    return out


def write_units(bp: Blueprint, directory: Path, per_component: bool = False,
                install_path: str | None = None, user: str | None = None,
                station: str | None = None, overrides: list[str] | None = None) -> list[Path]:
    """Write the units (and a copy of the blueprint to install) into ``directory``."""
    made = units(bp, per_component, install_path, user, station, overrides)
    try:
        directory.mkdir(parents=True, exist_ok=True)
        written = []
        for fname, text in made.items():
            path = directory / fname
            path.write_text(text, encoding="utf-8")
            written.append(path)
        copy = directory / f"{bp.name}.xml"
        if Path(bp.file).absolute() != copy.absolute():
            shutil.copyfile(bp.file, copy)
        written.append(copy)
    except OSError as exc:
        raise SupervisorError(f"{directory}: cannot write the units ({exc.strerror})") from None
    return written
