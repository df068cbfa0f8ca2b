"""A live simulation's checkpoint (the autosave's ``session`` record) and the replay of
its log after it (``station sim --recover``): the player, brush and counters as they were,
then every later record applied between the same two steps as it was live."""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Any

from station.brush.deformable import DeformableBrush
from station.brush.stamp import BrushSettings, RoundBrush
from station.errors import BadInput
from station.events import PenSample
from station.sim import recovery
from station.sim.live_config import RECOVERED_STROKE_GRACE_S, SILENCE_INTERVALS, DeviceState

if TYPE_CHECKING:
    from station.sim.live import LiveCore

log = logging.getLogger("station.sim.live")


def session(core: LiveCore) -> dict[str, Any]:
    """The player's, brush's and counters' state an autosave keeps beside the canvas,
    and how many log records it covers."""
    p, b, c = core.player, core.player.brush, core.counters
    return {
        "version": recovery.CHECKPOINT_VERSION,
        "log": {"path": str(core.log_path), "header": core.header_line,
                "records": core.journal.records_written},
        "player": {
            "steps": p.counters.steps, "waited": p.waited, "last_t": p.last_t,
            "profile": p.profile, "brush": b.settings.to_args(),
            "layer_pigments": sorted(p.layer_pigments),
            "samples": p.counters.samples, "commands": p.counters.commands,
            "skipped_commands": p.counters.skipped_commands,
            "waited_s": p.counters.waited_s,
            "stamps": b.stamps, "brush_samples": b.samples,
            "eraser_samples": b.eraser_samples, "strokes": b.strokes,
            **({"deformable": b.snapshot()} if isinstance(b, DeformableBrush) else {}),
            # whether the round brush's tip still carries the bead of its last dip
            **({"bead_ready": b.bead_ready} if isinstance(b, RoundBrush) else {}),
        },
        "live": {"last_t": core._last_t, "samples": c.samples, "commands": c.commands,
                 "bad_commands": c.bad_commands, "bad_samples": c.bad_samples,
                 "dropped_sources": c.dropped_sources,
                 "synthetic_pen_ups": c.synthetic_pen_ups},
    }

def restore(core: LiveCore, s: dict[str, Any]) -> None:
    """Player and counters as the checkpoint left them (recovery.plan checked it)."""
    p, ps, ls = core.player, s["player"], s["live"]
    p.counters.steps = int(ps["steps"])
    p.waited, p.last_t = float(ps["waited"]), float(ps["last_t"])
    a = ps["brush"]
    # the saved settings are already scaled to the canvas; _use swaps in a deformable
    # brush when the kind asks for one
    p._use(BrushSettings(str(a["kind"]), float(a["size"]), float(a["water"]),
                         {str(k): float(v) for k, v in a["pigment"].items()}))
    b = p.brush
    if isinstance(b, DeformableBrush) and "deformable" in ps:
        try:
            b.restore(ps["deformable"])
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            core._warn(f"recovery: the deformable brush's state was not restored ({exc}); "
                       "it starts freshly loaded")
    if isinstance(b, RoundBrush) and "bead_ready" in ps:  # _use dipped it afresh
        b.bead_ready = bool(ps["bead_ready"])
    p.layer_pigments = set(ps["layer_pigments"])
    p.counters.samples = int(ps["samples"])
    p.counters.commands = {str(k): int(v) for k, v in ps["commands"].items()}
    p.counters.skipped_commands = {str(k): int(v)
                                   for k, v in ps["skipped_commands"].items()}
    p.counters.waited_s = float(ps["waited_s"])
    b.stamps, b.samples = int(ps["stamps"]), int(ps["brush_samples"])
    b.eraser_samples, b.strokes = int(ps["eraser_samples"]), int(ps["strokes"])
    core._last_t = float(ls["last_t"])
    for k in ("samples", "commands", "bad_commands", "bad_samples", "dropped_sources",
              "synthetic_pen_ups"):
        setattr(core.counters, k, int(ls[k]))

def replay(core: LiveCore, plan: recovery.Plan) -> None:
    """Apply the log records after the checkpoint exactly as they were applied
    live (each after ``floor((t + waited)·rate)`` steps), then continue the
    session clock from there."""
    p = core.player
    last_seq = plan.seqs_before()
    for rec in plan.records():
        while p.counters.steps < p.steps_due(rec.t):
            core.step()
        try:
            p.apply(rec)
        except BadInput as exc:  # not in a log this process wrote; counted anyway
            core._warn(f"recovery: record not applied: {exc}")
            continue
        core._last_t = max(core._last_t, rec.t)
        if isinstance(rec, PenSample):
            dev = core.devices.setdefault(rec.device, DeviceState(last_seen=0.0))
            dev.touching, dev.last_sample = rec.touching and rec.proximity, rec
            if rec.seq:
                last_seq[rec.device] = rec.seq
            core.counters.samples += 1
        else:
            core.counters.commands += 1
            if rec.cmd == "wait":
                while p.counters.steps < p.steps_due(rec.t):
                    core.step()
    # The clock goes on at the start of the next step's slot: that step runs first,
    # with whatever stamps are pending (or were put into the canvas by a final
    # autosave), exactly as a replay of the continued log runs it.
    core.start = time.monotonic() - ((p.counters.steps + 1) / p.rate - p.waited)
    now = time.monotonic()
    for name in last_seq:  # a device heard only before the autosave is resumed too
        core.devices.setdefault(name, DeviceState(last_seen=now))
    for name, dev in core.devices.items():
        dev.last_seen = now
        dev.resume_seq = last_seq.get(name)
        if dev.touching:  # a stroke open at the crash: ends unless its device speaks
            dev.heartbeat_s = RECOVERED_STROKE_GRACE_S / SILENCE_INTERVALS
    log.warning("recovered %s: %d records replayed after the autosave (%d steps)",
                plan.log_path, plan.replayed, p.counters.steps)
