"""Scripted behaviour: event rules from a fixed vocabulary (no code runs from XML).

Events (``<on event=…>``):

``started``               every component is up
``idle`` (``after=``)     a painting component took no pen sample for that long,
                          after having taken some (fires once per idle period)
``device-unplugged``      a device fell silent (the sim's ``silent_devices``);
                          ``device=`` narrows it to one device name
``device-replugged``      a silent device speaks again
``component-restarted``   the supervisor restarted a component (``component=``)
``stopping``              the station is about to stop (before anything is stopped)

Actions: ``save`` (checkpoint), ``save-to-gallery``, ``clear``, ``dry``,
``new-layer``, ``show-message text=…``, ``restart component=…``.  The engine
here only decides *which* rules fire; :mod:`station.blueprint.supervisor`
carries the actions out.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from station.blueprint.model import Rule


@dataclass(frozen=True)
class Fired:
    """A rule that fired, on which painting component, and why."""

    rule: Rule
    target: str | None
    detail: dict[str, object] = field(default_factory=dict)


@dataclass
class _Painter:
    samples: int = -1
    changed_at: float = 0.0
    armed: bool = False
    done: set[int] = field(default_factory=set)  # idle rules fired in this idle period
    silent: frozenset[str] = frozenset()


class RuleEngine:
    """Turns statuses, time and supervisor events into fired rules."""

    def __init__(self, rules: list[Rule], painters: list[str]) -> None:
        self.rules = rules
        self.painters = painters
        self.state = {p: _Painter() for p in painters}

    def _target(self, rule: Rule) -> str | None:
        if rule.component is not None:
            return rule.component
        return self.painters[0] if self.painters else None

    def on_status(self, component: str, status: dict[str, Any], now: float) -> list[Fired]:
        st = self.state.get(component)
        if st is None:
            return []
        samples = status.get("samples")
        if isinstance(samples, int) and samples != st.samples:
            if st.samples >= 0 and samples > st.samples:
                st.armed, st.done = True, set()
            st.samples, st.changed_at = samples, now
        silent = frozenset(str(d) for d in status.get("silent_devices") or ())
        gone, back = silent - st.silent, st.silent - silent
        st.silent = silent
        fired = []
        for rule in self.rules:
            if self._target(rule) != component:
                continue
            if rule.event == "device-unplugged":
                devs = [d for d in sorted(gone) if rule.device in (None, d)]
            elif rule.event == "device-replugged":
                devs = [d for d in sorted(back) if rule.device in (None, d)]
            else:
                continue
            fired += [Fired(rule, component, {"device": d}) for d in devs]
        return fired

    def on_tick(self, now: float) -> list[Fired]:
        fired = []
        for name, st in self.state.items():
            if not st.armed:
                continue
            for i, rule in enumerate(self.rules):
                if (rule.event == "idle" and self._target(rule) == name and i not in st.done
                        and now - st.changed_at >= (rule.after_s or 0.0)):
                    st.done.add(i)  # once per idle period; the next pen sample re-arms
                    fired.append(Fired(rule, name, {"idle_s": round(now - st.changed_at, 3)}))
        return fired

    def on_event(self, event: str, component: str | None = None) -> list[Fired]:
        """``started``, ``stopping``, ``component-restarted`` (with the component)."""
        out = []
        for r in self.rules:
            if r.event != event or (component is not None and r.component not in (None,
                                                                                   component)):
                continue
            target = r.component if r.component in self.state else (
                self.painters[0] if self.painters else None)
            out.append(Fired(r, target, {"component": component} if component else {}))
        return out
