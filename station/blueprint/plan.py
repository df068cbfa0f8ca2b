"""Wiring checks and resolution: a :class:`~station.blueprint.model.Blueprint` becomes
a :class:`Plan` of processes with their command lines, endpoints and start order.

Checks (each names the element and line, :class:`BlueprintError`, exit 2):
duplicate ids; a ``<requires from>`` naming no component, or a component that
does not provide that interface; a required interface nothing provides (or too
many providers); a pen source nobody consumes; two components binding one
endpoint, port, device or output file; rules naming what is not there.

Endpoints: every ipc socket the station makes lives in the run directory
(``ipc:///RUN/ID.pen`` …), and children get ``STATION_RUNTIME_DIR=RUN`` so an
``ipc:NAME`` written in the blueprint lands there too.  A ``<bus>`` bound on tcp
is CURVE-authenticated: every process reaching it over tcp (sources on its ``pub``
side, sims, kiosks and recorders on its ``sub`` side) gets its ``keys=`` directory
as ``--keys``.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

from station.blueprint.catalog import KINDS
from station.blueprint.model import (
    Blueprint,
    BlueprintError,
    Component,
    Where,
    parse_duration,
)
from station.canvas.palette import default_palette
from station.drivers.pipeline import DeviceSpec

DEFAULT_RESTART = "on-failure"
DEFAULT_RESTART_DELAY_S = 0.5
# The back-off's floor: below it a crashing component is a busy loop of process starts
MIN_RESTART_DELAY_S = 0.1
# Crashes in a row (each within the supervisor's STABLE_S of its start) before the
# supervisor gives up on a component: 0.1 s doubling to 30 s is about two minutes
DEFAULT_RESTART_LIMIT = 10
SOURCE_KINDS = ("driver", "haptic", "replay")


@dataclass
class Process:
    """One component as a process: how to start it, what it binds, how to reach it."""

    id: str
    kind: str
    argv: list[str]  # arguments after ``station``
    where: Where
    recover_argv: list[str] | None = None  # the sim after a crash (--recover LOG)
    restart: str = DEFAULT_RESTART
    restart_delay_s: float = DEFAULT_RESTART_DELAY_S
    restart_limit: int = DEFAULT_RESTART_LIMIT
    binds: list[str] = field(default_factory=list)
    status: str | None = None  # endpoint the supervisor subscribes to for status
    cmd: str | None = None  # endpoint the supervisor sends commands to
    log: Path | None = None  # the sim's session log
    outputs: list[Path] = field(default_factory=list)
    devices: list[str] = field(default_factory=list)  # device nodes / classes it opens
    source: bool = False


@dataclass(frozen=True)
class Edge:
    """``provider`` --interface--> ``consumer`` (for the diagram)."""

    provider: str
    consumer: str
    interface: str


@dataclass
class Plan:
    blueprint: Blueprint
    run_dir: Path
    workdir: Path
    processes: list[Process]  # in start order
    edges: list[Edge]
    galleries: dict[str, Path]
    calibrations: dict[str, Path]

    def process(self, ident: str) -> Process:
        for p in self.processes:
            if p.id == ident:
                return p
        raise KeyError(ident)


# -- checks ---------------------------------------------------------------------------
def check(bp: Blueprint) -> None:
    """Every wiring check; the first failure is raised."""
    seen: dict[str, Component] = {}
    for c in bp.components:
        if c.id in seen:
            raise BlueprintError(f"duplicate id {c.id!r} (first at line {seen[c.id].where.line})",
                                 str(c.where))
        seen[c.id] = c
    for c in bp.components:
        kind = KINDS[c.kind]
        counts: dict[str, int] = {}
        for w in c.requires:
            provider = seen.get(w.provider)
            if provider is None:
                raise BlueprintError(f"unknown component {w.provider!r}", str(w.where))
            if provider is c:
                raise BlueprintError("a component cannot require itself", str(w.where))
            if w.interface not in KINDS[provider.kind].provides:
                raise BlueprintError(
                    f"<{provider.kind} id=\"{provider.id}\"> does not provide {w.interface!r}",
                    str(w.where))
            if c.kind == "bus" and provider.kind == "bus":
                raise BlueprintError("a <bus> takes pens from sources, not from another bus",
                                     str(w.where))
            if w.interface not in kind.requires:
                raise BlueprintError(f"<{c.kind}> requires no {w.interface!r}", str(w.where))
            counts[w.interface] = counts.get(w.interface, 0) + 1
        for interface, (lo, hi) in kind.requires.items():
            n = counts.get(interface, 0)
            if n < lo:
                raise BlueprintError(f"unsatisfied requirement: needs {interface!r} "
                                     f"(<requires interface=\"{interface}\" from=\"ID\"/>) "
                                     "and nothing provides it", str(c.where))
            if n > hi:
                hint = "; put a <bus> between them" if interface == "pen" else ""
                raise BlueprintError(f"takes at most {hi} {interface!r} provider(s), "
                                     f"{n} wired{hint}", str(c.where))
    _check_cycles(bp)
    consumers = _consumers(bp)
    for c in bp.components:
        if "pen" in KINDS[c.kind].provides and not consumers.get(c.id):
            raise BlueprintError(f"no consumer: nothing requires its 'pen' (wire it with "
                                 f"<requires interface=\"pen\" from=\"{c.id}\"/>)", str(c.where))
    for c in bp.components:
        _check_attrs(c)
    _check_rules(bp, seen)


def _consumers(bp: Blueprint) -> dict[str, list[tuple[Component, str]]]:
    out: dict[str, list[tuple[Component, str]]] = {}
    for c in bp.components:
        for w in c.requires:
            out.setdefault(w.provider, []).append((c, w.interface))
    return out


def _check_cycles(bp: Blueprint) -> None:
    by_id = bp.by_id()
    state: dict[str, int] = {}

    def visit(c: Component) -> None:
        state[c.id] = 1
        for w in c.requires:
            p = by_id[w.provider]
            if state.get(p.id) == 1:
                raise BlueprintError(f"wiring loop through {p.id!r}", str(w.where))
            if not state.get(p.id):
                visit(p)
        state[c.id] = 2

    for c in bp.components:
        if not state.get(c.id):
            visit(c)


def _check_attrs(c: Component) -> None:
    where = str(c.where)
    if c.kind in ("driver", "haptic"):
        device, vid = c.get("device"), c.get("vid")
        if bool(device) == bool(vid):
            raise BlueprintError("give device=\"SPEC\" or vid=/pid= (one of them)", where)
        if vid and not c.get("pid"):
            raise BlueprintError("vid= needs pid=", where)
        if device:
            try:
                spec = DeviceSpec.parse(device)
            except BlueprintError:
                raise
            except Exception as exc:  # DeviceSpecError: its message names the SPEC
                raise BlueprintError(str(exc).replace("--device: ", ""), where) from None
            haptic = spec.scheme in ("serial", "serial-mock")
            if haptic != (c.kind == "haptic"):
                raise BlueprintError("serial: devices are <haptic>, pens are <driver>"
                                     if haptic else "a <haptic> device is serial: or "
                                     "serial-mock:", where)
    for attr in ("restart-delay", "autosave", "attract-after", "idle-timeout", "duration",
                 "heartbeat"):
        if c.get(attr) is not None:
            parse_duration(c.attrs[attr], f"{where} {attr}=")
    if c.get("restart-delay") is not None and \
            parse_duration(c.attrs["restart-delay"], str(where)) < MIN_RESTART_DELAY_S:
        raise BlueprintError(f"restart-delay={c.attrs['restart-delay']!r} is below the "
                             f"{MIN_RESTART_DELAY_S * 1000:.0f}ms floor (a crashing component "
                             "would restart in a busy loop)", where)
    if c.kind == "replay":
        speed = c.get("speed", "max") or "max"
        if speed != "max":
            try:
                ok = 0.01 <= float(speed) <= 1000
            except ValueError:
                ok = False
            if not ok:
                raise BlueprintError(f"speed={speed!r}: a number 0.01..1000 or max", where)
    if c.get("keep-days") is not None and not 0 < float(c.attrs["keep-days"]) < 1e6:
        raise BlueprintError(f"keep-days={c.attrs['keep-days']!r}: a number of days > 0",
                             where)
    if c.get("per-client") is not None and not 1 <= int(c.attrs["per-client"]) <= 1000:
        raise BlueprintError(f"per-client={c.attrs['per-client']!r}: 1..1000", where)
    if c.kind == "sim" and c.get("resume") and (c.get("width") or c.get("height")):
        raise BlueprintError("resume= takes the size of the saved state; drop width/height",
                             where)
    if c.kind == "sim" and c.get("pigment") and c.attrs["pigment"] not in default_palette():
        raise BlueprintError(f"pigment={c.attrs['pigment']!r} is not in the palette", where)


def _check_rules(bp: Blueprint, by_id: dict[str, Component]) -> None:
    painters = [c for c in bp.components if KINDS[c.kind].paints]
    galleries = [c for c in bp.components if c.kind == "gallery"]
    for rule in bp.rules:
        target = None
        if rule.component is not None:
            target = by_id.get(rule.component)
            if target is None:
                raise BlueprintError(f"unknown component {rule.component!r}", str(rule.where))
        elif rule.event in ("idle", "device-unplugged", "device-replugged"):
            if not painters:
                raise BlueprintError(f"a {rule.event!r} rule needs a <sim> or <kiosk>",
                                     str(rule.where))
            target = painters[0]
        for action in rule.actions:
            if action.name == "restart":
                victim = action.attrs["component"]
                if victim not in by_id or not KINDS[by_id[victim].kind].process:
                    raise BlueprintError(f"no process component {victim!r} to restart",
                                         str(action.where))
                continue
            if action.name == "show-message":
                continue
            painter = target if target is not None and KINDS[target.kind].paints else (
                painters[0] if painters else None)
            if painter is None:
                raise BlueprintError(f"<{action.name}/> needs a <sim> or <kiosk>",
                                     str(action.where))
            if action.name == "save-to-gallery" and painter.kind == "sim":
                ident = action.attrs.get("gallery")
                if ident is not None and (ident not in by_id or by_id[ident].kind != "gallery"):
                    raise BlueprintError(f"no <gallery id=\"{ident}\">", str(action.where))
                if ident is None and not galleries:
                    raise BlueprintError("<save-to-gallery/> needs a <gallery>",
                                         str(action.where))


# -- resolution -----------------------------------------------------------------------
def resolve(bp: Blueprint, run_dir: Path, workdir: Path, stamp: str | None = None) -> Plan:
    """Check ``bp`` and turn it into processes (see the module docstring)."""
    check(bp)
    run_dir = run_dir.absolute()
    workdir = workdir.absolute()
    base = Path(bp.file).absolute().parent
    stamp = stamp or time.strftime("%Y%m%d-%H%M%S")
    by_id = bp.by_id()
    consumers = _consumers(bp)

    def out_path(text: str) -> Path:  # outputs: relative to the working directory
        p = Path(text).expanduser()
        return p if p.is_absolute() else workdir / p

    def in_path(text: str) -> Path:  # inputs: relative to the blueprint
        p = Path(text).expanduser()
        return p if p.is_absolute() else base / p

    def ipc(name: str) -> str:
        return f"ipc://{run_dir}/{name}"

    galleries = {c.id: out_path(c.attrs["dir"]) for c in bp.components if c.kind == "gallery"}
    calibrations = {c.id: in_path(c.attrs["file"])
                    for c in bp.components if c.kind == "calibration"}
    pen_out: dict[str, str] = {}  # provider id -> endpoint its consumers connect to
    procs: dict[str, Process] = {}
    for c in bp.components:
        if c.kind == "bus":
            pub = c.get("pub") or ipc(f"{c.id}.pub")
            sub = c.get("sub") or ipc(f"{c.id}.sub")
            argv = ["bus", "--pub", pub, "--sub", sub]
            if c.get("keys"):
                argv += ["--keys", str(in_path(c.attrs["keys"]))]
            procs[c.id] = _proc(c, argv, binds=[_norm(pub, run_dir), _norm(sub, run_dir)])
            pen_out[c.id] = sub
    for c in bp.components:
        if c.kind in ("driver", "haptic", "replay"):
            direct = [k for k, _ in consumers.get(c.id, [])]
            via_bus = [k for k in direct if k.kind == "bus"]
            if via_bus and len(via_bus) != len(direct):
                raise BlueprintError("a pen source goes either to one <bus> or straight to its "
                                     "consumers, not both", str(c.where))
            if len(via_bus) > 1:
                raise BlueprintError("a pen source publishes to one <bus>", str(c.where))
            if via_bus:
                bus = by_id[via_bus[0].id]
                target = ">" + (bus.get("pub") or ipc(f"{bus.id}.pub"))
                binds: list[str] = []
                waits = 1
            else:
                ep = ipc(f"{c.id}.pen")
                target, binds, waits = "@" + ep, [_norm(ep, run_dir)], len(direct)
                pen_out[c.id] = ep
            procs[c.id] = _source(c, target, binds, waits, calibrations, in_path)
            if c.kind == "haptic":  # its forces come from the sims and kiosks it paints on
                readers = direct + [k for b in via_bus for k, _ in consumers.get(b.id, [])]
                for r in readers:
                    if r.kind in ("sim", "kiosk"):
                        procs[c.id].argv += ["--haptic-bus", ">" + ipc(f"{r.id}.status")]
            if via_bus:  # a tcp pub side: the bus's key directory (else the default one)
                procs[c.id].argv += _keys_argv(by_id[via_bus[0].id], target, in_path)
    for c in bp.components:
        if c.kind == "sim":
            procs[c.id] = _sim(c, pen_out[c.requires[0].provider], ipc, out_path, in_path,
                               bp.name, stamp, run_dir)
        elif c.kind == "kiosk":
            procs[c.id] = _kiosk(c, pen_out[c.requires[0].provider], ipc, out_path, galleries,
                                 run_dir)
        elif c.kind == "recorder":
            out = out_path(c.attrs["output"])
            argv = ["record", "--bus", pen_out[c.requires[0].provider], "-o", str(out)]
            if c.get("duration"):
                argv += ["--duration", _secs(c.attrs["duration"])]
            procs[c.id] = _proc(c, argv, outputs=[out])
        if c.kind in ("sim", "kiosk", "recorder"):  # a tcp sub side: the bus's keys
            provider = by_id[c.requires[0].provider]
            extra = _keys_argv(provider, pen_out[provider.id], in_path)
            proc = procs[c.id]
            proc.argv += extra
            if proc.recover_argv is not None:  # a crashed sim restarts on the same bus
                proc.recover_argv += extra
    _check_clashes(bp, procs, run_dir)
    order = _start_order(bp, procs)
    edges = [Edge(w.provider, c.id, w.interface) for c in bp.components for w in c.requires]
    return Plan(bp, run_dir, workdir, [procs[i] for i in order], edges, galleries, calibrations)


def _keys_argv(bus: Component, endpoint: str, in_path: object) -> list[str]:
    """``--keys DIR`` for a process that reaches ``bus`` over tcp (CURVE) when the
    ``<bus>`` names its key directory; without ``keys=`` the process uses the default
    directory (~/.config/station/keys), as ``station bus`` does."""
    if bus.kind != "bus" or not endpoint.lstrip("@>").startswith("tcp://") \
            or not bus.get("keys"):
        return []
    return ["--keys", str(in_path(bus.attrs["keys"]))]  # type: ignore[operator]


def _secs(text: str) -> str:
    return f"{parse_duration(text, 'duration'):g}"


def _norm(endpoint: str, run_dir: Path) -> str:
    """An endpoint as the socket it names (for clash checks)."""
    ep = endpoint.lstrip("@>")
    if ep == "ipc":
        return f"ipc://{run_dir}/bus"
    if ep.startswith("ipc:") and not ep.startswith("ipc://"):
        return f"ipc://{run_dir}/{ep[4:]}"
    if ep.startswith("tcp://"):
        host, _, port = ep[6:].rpartition(":")
        return f"tcp://{host or '127.0.0.1'}:{port}"
    return ep


def _proc(c: Component, argv: list[str], **kw: object) -> Process:
    restart = c.get("restart") or DEFAULT_RESTART
    delay = parse_duration(c.attrs["restart-delay"], str(c.where)) if c.get("restart-delay") \
        else DEFAULT_RESTART_DELAY_S
    limit = int(c.attrs["restart-limit"]) if c.get("restart-limit") else DEFAULT_RESTART_LIMIT
    return Process(id=c.id, kind=c.kind, argv=argv, where=c.where, restart=restart,
                   restart_delay_s=max(delay, MIN_RESTART_DELAY_S), restart_limit=limit,
                   **kw)  # type: ignore[arg-type]


def _device_nodes(spec: str) -> list[str]:
    """What a device SPEC opens, for systemd's DeviceAllow= (mocks open nothing)."""
    scheme, _, rest = spec.partition(":")
    target = rest.partition("?")[0]
    if scheme in ("evdev", "hidraw") and target.startswith("/dev/"):
        return [target]
    if scheme == "serial":
        return [target] if target.startswith("/dev/") else ["char-ttyACM", "char-ttyUSB"]
    return {"hidraw": ["char-hidraw"], "hidapi": ["char-hidraw"], "usb": ["char-usb_device"],
            "evdev": ["char-input"], "auto": ["char-input", "char-hidraw"]}.get(scheme, [])


def _source(c: Component, target: str, binds: list[str], waits: int,
            calibrations: dict[str, Path], in_path: object) -> Process:
    if c.kind == "replay":
        trace = in_path(c.attrs["trace"])  # type: ignore[operator]
        argv = ["replay", str(trace), "--bus", target, "--speed", c.get("speed", "1.0") or "1.0",
                "--name", c.id, "--wait-subscribers", str(waits)]
        return _proc(c, argv, binds=binds, source=True)
    if c.get("device"):
        spec = c.attrs["device"]
    else:  # a selector: hidapi finds the device by its ids wherever it is plugged
        spec = f"hidapi:{c.attrs['vid'].lower()}:{c.attrs['pid'].lower()}"
    argv = ["driver", "--device", spec, "--bus", target, "--name", c.get("name") or c.id,
            "--wait-subscribers", str(waits)]
    cal = [w for w in c.requires if w.interface == "calibration"]
    if cal:
        argv += ["--calibration", str(calibrations[cal[0].provider])]
    elif c.get("calibration"):
        argv += ["--calibration", c.attrs["calibration"]]
    for attr, flag in (("area", "--area"), ("smoothing", "--smoothing"),
                       ("pressure-curve", "--pressure-curve")):
        if c.get(attr):
            argv += [flag, c.attrs[attr]]
    if c.get("heartbeat"):
        argv += ["--heartbeat", _secs(c.attrs["heartbeat"])]
    if c.get("wait") == "true" or c.get("vid"):
        argv.append("--wait")
    return _proc(c, argv, binds=binds, source=True, devices=_device_nodes(spec))


def _sim(c: Component, bus: str, ipc: object, out_path: object, in_path: object, name: str,
         stamp: str, run_dir: Path) -> Process:
    status, cmd = ipc(f"{c.id}.status"), ipc(f"{c.id}.cmd")  # type: ignore[operator]
    log = out_path(c.get("log") or f"sessions/{name}-{c.id}-{stamp}.jsonl")  # type: ignore[operator]
    common = ["--bus", bus, "--status", "@" + status, "--cmd", "@" + cmd]
    if c.get("backend"):
        common += ["--backend", c.attrs["backend"]]
    if c.get("autosave"):
        common += ["--autosave", _secs(c.attrs["autosave"])]
    outputs = [log]
    for attr in ("png", "state"):
        if c.get(attr):
            path = out_path(c.attrs[attr])  # type: ignore[operator]
            common += [f"--{attr}", str(path)]
            outputs.append(path)
    argv = ["sim", *common, "--log", str(log)]
    if c.get("width") or c.get("height"):
        argv += ["--size", f"{c.get('width') or 800}x{c.get('height') or 600}"]
    for attr in ("profile", "seed", "rate"):
        if c.get(attr):
            argv += [f"--{attr}", c.attrs[attr]]
    brush = _start_brush(c)
    if brush:
        argv += ["--brush", brush]
    if c.get("resume"):
        argv += ["--resume", str(in_path(c.attrs["resume"]))]  # type: ignore[operator]
    recover = ["sim", *common, "--recover", str(log)]
    return _proc(c, argv, recover_argv=recover, binds=[_norm(status, run_dir),
                 _norm(cmd, run_dir)], status=status, cmd=cmd, log=log, outputs=outputs)


def _start_brush(c: Component) -> str | None:
    """A sim's brush-size=, brush-water=, pigment= and pigment-amount= as ``--brush``."""
    args: dict[str, object] = {}
    for attr, key in (("brush-size", "size"), ("brush-water", "water")):
        if c.get(attr):
            args[key] = float(c.attrs[attr])
    if c.get("pigment"):
        args["pigment"] = {c.attrs["pigment"]: float(c.get("pigment-amount") or 1.0)}
    return json.dumps(args) if args else None


def _kiosk(c: Component, bus: str, ipc: object, out_path: object,
           galleries: dict[str, Path], run_dir: Path) -> Process:
    status, cmd = ipc(f"{c.id}.status"), ipc(f"{c.id}.cmd")  # type: ignore[operator]
    argv = ["kiosk", "--bus", bus, "--status", "@" + status, "--cmd", "@" + cmd]
    if c.get("width") or c.get("height"):
        argv += ["--size", f"{c.get('width') or 800}x{c.get('height') or 600}"]
    for attr in ("profile", "backend", "seed", "rate", "monitor", "view", "base-url"):
        if c.get(attr):
            argv += [f"--{attr}", c.attrs[attr]]
    if c.get("windowed"):
        argv += ["--windowed", c.attrs["windowed"]]
    if c.get("autosave"):
        argv += ["--autosave", _secs(c.attrs["autosave"])]
    if c.get("attract-after"):
        argv += ["--attract-after", _secs(c.attrs["attract-after"])]
    if c.get("idle-timeout"):
        minutes = parse_duration(c.attrs["idle-timeout"], str(c.where)) / 60.0
        argv += ["--idle-minutes", f"{minutes:g}"]
    if c.get("vsync") == "false":
        argv.append("--no-vsync")
    serve = c.get("serve") or "none"
    argv += ["--serve", serve]
    for flag in ("gallery-index", "gallery-logs"):
        if c.get(flag) == "true":
            argv.append(f"--{flag}")
    for attr in ("keep-days", "per-client"):
        if c.get(attr):
            argv += [f"--{attr}", c.attrs[attr]]
    binds = [_norm(status, run_dir), _norm(cmd, run_dir)]
    if serve != "none":
        host, _, port = serve.rpartition(":")
        binds.append(f"tcp://{host or '0.0.0.0'}:{port}")
    gal = [w for w in c.requires if w.interface == "gallery"]
    outputs = []
    if gal:
        argv += ["--gallery", str(galleries[gal[0].provider])]
        outputs.append(galleries[gal[0].provider])
    return _proc(c, argv, binds=binds, status=status, cmd=cmd, outputs=outputs,
                 devices=["/dev/dri"])


def _check_clashes(bp: Blueprint, procs: dict[str, Process], run_dir: Path) -> None:
    owners: dict[str, str] = {}
    by_id = bp.by_id()
    for p in procs.values():
        for what, items in (("endpoint", p.binds), ("output file", [str(o) for o in p.outputs]),
                            ("device", [d for d in p.devices if d.startswith("/dev/input/")
                                        or d.startswith("/dev/hidraw")])):
            for item in items:
                if item.startswith("tcp://"):
                    continue  # below: a wildcard address clashes with every host
                key = f"{what} {item}"
                if key in owners:
                    other = owners[key]
                    by = "itself" if other == p.id else \
                        f"{other!r} (line {by_id[other].where.line})"
                    raise BlueprintError(f"{what} clash: {item} is already bound by {by}",
                                         str(p.where))
                owners[key] = p.id
    tcp: list[tuple[str, str, str]] = []  # (host, port, owner)
    for p in procs.values():
        for b in p.binds:
            if not b.startswith("tcp://"):
                continue
            host, _, port = b[6:].rpartition(":")
            for h, q, owner in tcp:
                if q == port and (h == host or "0.0.0.0" in (h, host)):
                    raise BlueprintError(f"endpoint clash: port {port} is already bound by "
                                         f"{owner!r} (line {by_id[owner].where.line})",
                                         str(p.where))
            tcp.append((host, port, p.id))


def _start_order(bp: Blueprint, procs: dict[str, Process]) -> list[str]:
    """Buses first (a bus before the buses that feed it), then the consumers, then the pen
    sources: a source starts once everything listening to it is there, so no sample is
    painted by nobody.  Document order within each group."""
    order: list[str] = []

    order += [c.id for c in bp.components if c.kind == "bus"]
    order += [c.id for c in bp.components if c.id in procs and c.kind not in ("bus",)
              and c.kind not in SOURCE_KINDS]
    order += [c.id for c in bp.components if c.kind in SOURCE_KINDS]
    return order
