"""The station blueprint: an XML document saying what a station is made of and how it
is wired (chapter 2 of the dissertation), checked, resolved into processes, run
under a supervisor, and turned into systemd units.  See docs/blueprint.md.

Layers: :mod:`~station.blueprint.load` (XML + schema + overrides) →
:mod:`~station.blueprint.model` (value types) → :mod:`~station.blueprint.plan`
(wiring checks, processes) → :mod:`~station.blueprint.supervisor` (running) with
:mod:`~station.blueprint.rules` (scripted behaviour),
:mod:`~station.blueprint.systemd` and :mod:`~station.blueprint.diagram`.
"""
