"""The resolved wiring as text (for people) or Graphviz dot."""

from __future__ import annotations

import shlex

from station.blueprint.catalog import KINDS
from station.blueprint.plan import Plan

_SHAPES = {"bus": "diamond", "gallery": "folder", "calibration": "note", "sim": "box3d",
           "kiosk": "box3d", "recorder": "cylinder"}


def text(plan: Plan) -> str:
    bp = plan.blueprint
    lines = [f'station "{bp.name}" ({bp.file})' + (f": {bp.description}" if bp.description
                                                    else "")]
    lines.append("wiring:")
    width = max((len(e.provider) for e in plan.edges), default=4)
    for e in plan.edges:
        src, dst = bp.component(e.provider), bp.component(e.consumer)
        lines.append(f"  {e.provider:<{width}} ({src.kind}) --{e.interface}--> "
                     f"{e.consumer} ({dst.kind})")
    lines.append("processes, in start order (stopped in reverse):")
    for i, proc in enumerate(plan.processes, 1):
        lines.append(f"  {i}. {proc.id} [{proc.kind}, restart={proc.restart}]: "
                     f"station {shlex.join(proc.argv)}")
        if proc.recover_argv:
            lines.append(f"     after a crash: station {shlex.join(proc.recover_argv)}")
        if proc.binds:
            lines.append(f"     binds {', '.join(proc.binds)}")
    resources = [c for c in bp.components if not KINDS[c.kind].process]
    if resources:
        lines.append("resources:")
        for c in resources:
            path = plan.galleries.get(c.id) or plan.calibrations.get(c.id)
            lines.append(f"  {c.id} ({c.kind}): {path}")
    if bp.rules:
        lines.append("rules:")
        for r in bp.rules:
            cond = f"{r.event}" + (f" after {r.after_s:g} s" if r.after_s else "") + (
                f" on {r.component}" if r.component else "")
            acts = ", ".join(a.name + (f" {a.attrs}" if a.attrs else "") for a in r.actions)
            lines.append(f"  on {cond}: {acts}")
    return "\n".join(lines) + "\n"


def dot(plan: Plan) -> str:
    bp = plan.blueprint
    out = [f'digraph "{bp.name}" {{', "  rankdir=LR;", '  node [fontname="sans-serif"];']
    for c in bp.components:
        shape = _SHAPES.get(c.kind, "box")
        out.append(f'  "{c.id}" [label="{c.id}\\n<{c.kind}>", shape={shape}];')
    for e in plan.edges:
        out.append(f'  "{e.provider}" -> "{e.consumer}" [label="{e.interface}"];')
    for i, r in enumerate(bp.rules):
        label = r.event + (f" {r.after_s:g}s" if r.after_s else "")
        acts = "\\n".join(a.name for a in r.actions)
        out.append(f'  "rule{i}" [label="on {label}\\n{acts}", shape=plaintext];')
        if r.component:
            out.append(f'  "rule{i}" -> "{r.component}" [style=dashed];')
    out.append("}")
    return "\n".join(out) + "\n"
