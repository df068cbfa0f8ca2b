"""The blueprint's value types: components, wires, rules, and the errors of this layer.

A :class:`Blueprint` is what a blueprint file says after schema validation and
command-line overrides, before anything is resolved against the machine: every
element keeps its source line so a check can name it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from station.errors import BadInput, StationError


class BlueprintError(BadInput):
    """A blueprint that cannot work: schema, wiring, or an override (exit 2)."""


class SupervisorError(StationError):
    """The station could not be run (an environment problem, exit 1)."""


@dataclass(frozen=True)
class Where:
    """A place in a blueprint file: ``file:line <element id="…">``."""

    file: str
    line: int
    element: str
    id: str | None = None

    def __str__(self) -> str:
        ident = f' id="{self.id}"' if self.id else ""
        return f"{self.file}:{self.line}: <{self.element}{ident}>"


@dataclass(frozen=True)
class Wire:
    """One required interface connected to a provider: ``<requires interface from>``."""

    interface: str
    provider: str
    where: Where


@dataclass
class Component:
    """One ``<kind id=…>`` element: its attributes (strings, as written) and wires."""

    kind: str
    id: str
    attrs: dict[str, str]
    requires: list[Wire]
    where: Where

    def get(self, name: str, default: str | None = None) -> str | None:
        return self.attrs.get(name, default)


@dataclass(frozen=True)
class Action:
    """One action of a rule, from the fixed vocabulary (``save``, ``clear`` …)."""

    name: str
    attrs: dict[str, str]
    where: Where


@dataclass(frozen=True)
class Rule:
    """``<on event=… after=… component=…>`` and its actions, in order."""

    event: str
    after_s: float | None
    component: str | None
    device: str | None
    actions: tuple[Action, ...]
    where: Where


@dataclass
class Blueprint:
    """A validated blueprint document."""

    name: str
    file: str
    components: list[Component]
    rules: list[Rule] = field(default_factory=list)
    description: str = ""
    user: str | None = None

    def by_id(self) -> dict[str, Component]:
        return {c.id: c for c in self.components}

    def component(self, ident: str) -> Component:
        return self.by_id()[ident]


_DURATION = re.compile(r"([0-9]+(?:\.[0-9]+)?)(ms|s|min|h)?")
_UNIT_S = {"ms": 0.001, "s": 1.0, "min": 60.0, "h": 3600.0, None: 1.0}


def parse_duration(text: str, where: str) -> float:
    """``"300s"``, ``"250ms"``, ``"5min"``, ``"2h"``, ``"1.5"`` → seconds."""
    m = _DURATION.fullmatch(text.strip())
    if not m:
        raise BlueprintError(f"{text!r} is not a duration (300s, 250ms, 5min, 2h)", where)
    return float(m.group(1)) * _UNIT_S[m.group(2)]
