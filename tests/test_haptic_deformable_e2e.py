"""The deformable brush's force end to end: the wire message, the driver's contact models,
the sim's publishing hook, and the mock device feeling it (issue 15, item 3)."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import needs_pty
from haptic_fixtures import _limits_never_exceeded, realtime_host  # noqa: F401 - fixtures
from station.drivers.haptic import source as haptic_source
from station.drivers.haptic.contact import BrushState
from station.drivers.haptic.deformable import DeformableBrushContact, height_pressure
from station.drivers.normalise import NormaliserConfig
from station.drivers.pipeline import DeviceSpec, PenDriver, open_device
from station.drivers.transport.base import DeviceSpecError, EndOfStream

from station import wire
from station.brush.deformable import REACH, DeformableBrush
from station.bus import Publisher
from station.cli import main
from station.errors import WireError
from station.events import Command, PenSample, Tool
from station.sessionlog import read_session
from station.sim.live import LiveConfig, LiveCore

# -- the wire ----------------------------------------------------------------------------


def test_haptic_force_round_trip_and_validation() -> None:
    f = wire.HapticForce(t=1.25, fx=-0.1, fy=0.05, fz=1.5)
    frames = wire.encode("haptic.haptic-a", f, 7, 3)
    assert frames[1][3] == wire.KIND_HAPTIC_FORCE == 7
    env = wire.decode(frames)
    assert env.kind == "haptic" and env.value == f
    with pytest.raises(WireError, match="haptic force on topic"):
        wire.decode([b"pen.a", frames[1]])
    with pytest.raises(WireError, match="body is 31 bytes"):
        wire.decode([frames[0], frames[1][:-1]])
    bad = bytearray(frames[1])
    bad[-8:] = np.float64(np.nan).tobytes()
    with pytest.raises(WireError, match="fz"):
        wire.decode([frames[0], bytes(bad)])
    for kw in ({"fz": 1e4}, {"t": -1.0}, {"fx": math.inf}):
        with pytest.raises(Exception, match="outside"):
            wire.HapticForce(**{"t": 0.0, "fx": 0.0, "fy": 0.0, "fz": 0.0, **kw})


# -- the driver's configuration ----------------------------------------------------------


def test_contact_option_selects_the_model() -> None:
    cfg = haptic_source.haptic_config(DeviceSpec.parse("serial-mock:?contact=round"))
    assert cfg.contact is not None and cfg.reaction is None and cfg.pressure is None
    cfg = haptic_source.haptic_config(
        DeviceSpec.parse("serial-mock:?contact=deformable&shape=flat&tuft=8&reaction_rate=40"))
    assert cfg.contact is None and isinstance(cfg.reaction, DeformableBrushContact)
    assert cfg.reaction.shape.name == "flat" and cfg.reaction.tuft_mm == 8.0
    assert cfg.reaction_hz == 40.0 and cfg.surface is not None and cfg.pressure is not None
    cfg = haptic_source.haptic_config(DeviceSpec.parse("serial-mock:?contact=bus&friction=0.3"))
    assert cfg.contact is None and cfg.reaction is None
    assert cfg.surface is not None and cfg.surface.friction == 0.3
    for bad, msg in (("contact=soft", "contact='soft'"), ("contact=bus&hair=5", "hair="),
                     ("contact=deformable&shape=nope", "unknown brush shape"),
                     ("contact=bus&reaction_rate=50", "reaction_rate="),
                     ("tuft=5", "tuft= is for")):
        with pytest.raises(DeviceSpecError, match=msg):
            haptic_source.haptic_config(DeviceSpec.parse("serial-mock:?" + bad))


def test_bad_contact_flag_exits_2(tmp_path: Path, capsys) -> None:
    assert main(["driver", "--device", "serial-mock:?contact=sponge",
                 "--bus", f"ipc://{tmp_path}/bus"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "contact='sponge'" in err[0]


def test_height_pressure_inverts_the_brush_mapping() -> None:
    for p in (0.0, 0.2, 0.55, 1.0):
        z_tuft = 1.0 - REACH - 0.7 * p  # DeformableBrush.pose's ferrule height
        assert height_pressure(6.0 * z_tuft, 6.0, 0.7) == pytest.approx(p)
    assert height_pressure(20.0, 6.0, 0.7) == 0.0 and height_pressure(0.0, 6.0, 0.7) == 1.0


# -- the sim's publishing hook -----------------------------------------------------------


def _pen(t: float, device: str, pressure: float, touching: bool = True) -> PenSample:
    return PenSample(t=t, device=device, tool=Tool.PEN, x=0.5, y=0.5, pressure=pressure,
                     proximity=True, touching=touching)


def test_sim_publishes_the_deformable_brush_reaction(tmp_path: Path) -> None:
    core = LiveCore(LiveConfig(bus=None, width=48, height=32, backend="numpy",
                               log_path=str(tmp_path / "s.jsonl"), autosave=0))
    sent: list[tuple[str, wire.HapticForce]] = []
    rests: list[list[np.ndarray]] = []  # the brush's plastic state when each frame went

    def send(name: str, f: wire.HapticForce) -> None:
        sent.append((name, f))
        rests.append([st.rest.copy() for st in core.player.brush.spines])

    core.haptics.send = send
    core.haptics.wanted = lambda name: name == "haptic-a"  # LiveSim asks its publisher
    core.haptics.period = 0.0
    try:
        core.feed_sample(_pen(0.0, "haptic-a", 0.5))
        core.feed_sample(_pen(0.0, "tablet-b", 0.5))
        core.step()
        assert sent == []  # the round brush: the driver's own spring is its force
        assert core.feed_command(Command(t=0.0, cmd="brush", args={"kind": "round3d"}))
        assert isinstance(core.player.brush, DeformableBrush)
        fz = []
        for p in (0.1, 0.4, 0.8):
            sent.clear()
            core.feed_sample(_pen(0.0, "haptic-a", p))
            core.feed_sample(_pen(0.0, "tablet-b", p))
            core.step()
            assert [name for name, _ in sent] == ["haptic-a"]  # only haptic devices cost
            fz.append(sent[0][1].fz)
        assert 0.0 < fz[0] < fz[1] < fz[2]
        # the same force as the driver's model at the device height that pressure means,
        # with the painting brush's plastic state (its spines' rest angles)
        model = DeformableBrushContact()
        z_mm = 6.0 * height_inverse(0.8)
        assert fz[2] == pytest.approx(
            model.reaction(BrushState(0.0, (0, 0, z_mm)), rests[-1])[2], rel=1e-6)
        assert fz[2] != pytest.approx(model.reaction(BrushState(0.0, (0, 0, z_mm)))[2],
                                      rel=1e-3)  # the wet brush has taken a little set
        sent.clear()
        core.feed_sample(_pen(0.0, "haptic-a", 0.0, touching=False))
        core.step()
        assert [(n, f.fx, f.fy, f.fz) for n, f in sent] == [("haptic-a", 0.0, 0.0, 0.0)]
        assert core.haptics.errors == 0
    finally:
        core.finish()


def height_inverse(p: float) -> float:
    return 1.0 - REACH - 0.7 * p


# -- with the mock device ----------------------------------------------------------------


def _felt(mock, t0: float, t1: float) -> list[float]:
    return [f for t, f, _ in mock.applied if t0 <= t < t1]


@needs_pty
@pytest.mark.timeout(60)
@pytest.mark.usefixtures("realtime_host")
def test_driver_computes_the_deformable_force_and_the_stroke_presses(tmp_path: Path) -> None:
    spec = "serial-mock:?script=stroke&contact=deformable&max_force=1.5&slew=1000"
    log = tmp_path / "stroke.jsonl"
    assert main(["driver", "--device", spec, "--bus", f"ipc://{tmp_path}/bus",
                 "--jsonl", str(log), "--status-interval", "0.2"]) == 0
    mock = haptic_source._MOCKS[DeviceSpec.parse(spec).text]
    hover, early, late = _felt(mock, 0, 0.4), _felt(mock, 0.65, 0.9), _felt(mock, 1.3, 1.6)
    assert len(hover) > 300 and max(hover) == 0.0
    # pressing 1 mm into a 6 mm round tuft: the buckling tuft's ~0.4 N; 3-4 mm: ~0.6-0.8 N
    assert 0.25 < max(early) < max(late) - 0.1
    assert max(r.force.magnitude for r in mock.received) <= 1.5
    _, records = read_session(log)
    down = [r for r in records if isinstance(r, PenSample) and r.touching]
    assert len(down) > 300
    third = len(down) // 3  # pressure from the handle height: it rises as the hand presses
    assert np.mean([p.pressure for p in down[:third]]) + 0.2 < np.mean(
        [p.pressure for p in down[-third:]])


@needs_pty
@pytest.mark.timeout(60)
@pytest.mark.usefixtures("realtime_host")
def test_the_sim_paints_with_the_deformable_brush_and_the_mock_feels_it(tmp_path: Path
                                                                        ) -> None:
    """The mock is the input; the sim holds the deformable brush, paints, and sends its
    reaction over a real bus; the driver (contact=bus) renders it at the mock.

    One process here (the sim is its own process in a station): the mock sends 250
    poses/s so that painting each one with the deformable brush leaves the 1 kHz loop
    its share of the GIL on this loaded machine.
    """
    spec = "serial-mock:?script=stroke&contact=bus&max_force=1.5&slew=1000&pose_rate=250"
    endpoint = f"ipc://{tmp_path}/haptic"
    pub = Publisher(endpoint, bind=True)
    core = LiveCore(LiveConfig(bus=None, width=64, height=48, backend="numpy",
                               log_path=str(tmp_path / "s.jsonl"), autosave=0))
    sent: list[tuple[float, float]] = []

    def send(name: str, f: wire.HapticForce) -> None:
        sent.append((f.t, f.fz))
        pub.publish_haptic(name, f)

    core.haptics.send = send
    # as LiveSim does: only a device whose driver subscribed costs a solve
    core.haptics.wanted = lambda name: pub.wants(f"haptic.{name}")
    assert core.feed_command(Command(t=0.0, cmd="brush", args={"kind": "round3d", "size": 10.0}))
    for i in range(4):  # a stroke of another pen: the painting path compiled before the hand
        core.feed_sample(_pen(0.0, "warm-up", 0.5, touching=i < 3))
        core.step()
    sent.clear()
    stamps0 = core.player.brush.stamps
    paint0 = float(core.player.backend.state().p.sum())
    src = open_device(spec, name="haptic-t")
    mock = src.mock
    try:
        src.attach_bus(endpoint)
        assert pub.wait_for_subscribers(1, timeout=10.0)
        driver = PenDriver(src, NormaliserConfig(), live=True)
        try:
            while True:
                for s in driver.poll(0.01):
                    core.feed_sample(s)
                while core.steps_due() > 0:
                    core.step()
        except EndOfStream:
            pass
        assert core.haptics.frames > 20 and core.haptics.errors == 0
        assert src.session.stats.reaction_frames > 20
        # the sim's frames: zero while hovering, then the tuft's reaction once it touches
        forces = [f for _, f in sent]
        touch = next(i for i, f in enumerate(forces) if f > 0.0)
        assert touch > 5 and max(forces[:touch]) == 0.0 and max(forces) > 0.25
        # the mock felt them: nothing while hovering, the reaction while on the paper
        hover, on = _felt(mock, 0, 0.4), _felt(mock, 0.6, 1.6)
        assert max(hover) == 0.0
        assert max(on) > 0.2 and np.mean(on) > 0.05
        assert max(r.force.magnitude for r in mock.received) <= 1.5
        brush = core.player.brush
        assert isinstance(brush, DeformableBrush) and brush.stamps >= stamps0 + 5
        core.step()
        assert float(core.player.backend.state().p.sum()) > 2 * paint0  # and it painted
    finally:
        src.close()
        pub.close()
        core.finish()


class _Session:
    """What a ReactionWorker uses of a HapticSession."""

    def __init__(self, state: BrushState) -> None:
        self.state: BrushState | None = state
        self.gone = None
        self.frames: list[tuple[float | None, tuple[float, float, float]]] = []
        self.stats = type("S", (), {"reaction_s": 0.0})()

    def submit_reaction(self, force: tuple[float, float, float], t: float | None = None
                        ) -> None:
        self.frames.append((t, force))


@pytest.mark.timeout(60)
def test_reaction_process_answers_as_the_model_and_its_death_is_survived() -> None:
    from station.drivers.haptic.reaction import ReactionWorker

    state = BrushState(3.5, (1.0, 2.0, 3.0), (10.0, 0.0, 0.0))
    model = DeformableBrushContact()
    session = _Session(state)
    worker = ReactionWorker(session, model, rate_hz=50.0)  # type: ignore[arg-type]
    worker.start()
    try:
        assert worker.ready.wait(30.0)
        deadline = time.monotonic() + 10.0
        while len(session.frames) < 3 and time.monotonic() < deadline:
            time.sleep(0.01)
        expected = model.reaction(state)  # deterministic: the same solve, the same bits
        assert session.frames[0] == (3.5, expected) and expected[2] > 0.3
        assert worker._proc is not None
        worker._proc.kill()  # the solver process dies: the worker ends quietly, no frames
        worker._proc.wait()
        time.sleep(0.2)
        n = len(session.frames)
        time.sleep(0.2)
        assert len(session.frames) == n and not worker._thread.is_alive()
    finally:
        worker.stop()


def test_publisher_knows_who_wants_haptic_forces(tmp_path: Path) -> None:
    from station.bus import Subscriber

    endpoint = f"ipc://{tmp_path}/sim-status"
    pub = Publisher(endpoint, bind=True)
    everything = Subscriber(endpoint, topics=("",))
    try:
        assert pub.wait_for_subscribers(1, timeout=10.0)
        assert not pub.wants("haptic.hand")  # a subscriber of everything does not count
        driver = Subscriber(endpoint, topics=("haptic.hand",))
        assert pub.wait_for_subscribers(2, timeout=10.0)
        assert pub.wants("haptic.hand") and not pub.wants("haptic.other")
        second = Subscriber(endpoint, topics=("haptic.hand",))  # a second driver of the hand
        assert pub.wait_for_subscribers(3, timeout=10.0)
        second.close()
        deadline = time.monotonic() + 10.0
        while pub._topics.get(b"haptic.hand", 0) > 1:  # its unsubscription arrives
            assert time.monotonic() < deadline
            pub.poll_subscriptions()
            time.sleep(0.02)
        assert pub.wants("haptic.hand")  # the first driver still wants them
        driver.close()
        deadline = time.monotonic() + 10.0
        while pub.wants("haptic.hand"):  # its unsubscription arrives
            assert time.monotonic() < deadline
            time.sleep(0.02)
    finally:
        everything.close()
        pub.close()


def test_blueprint_points_a_haptic_driver_at_the_sims_it_paints_on(tmp_path: Path) -> None:
    from station.blueprint.load import load
    from station.blueprint.plan import resolve

    (tmp_path / "bp.xml").write_text("""<station name="h" version="1">
  <haptic id="hand" device="serial-mock:?script=stroke&amp;contact=bus"/>
  <driver id="pen" device="mock:intuos-pro-m"/>
  <bus id="hub"><requires interface="pen" from="hand"/><requires interface="pen" from="pen"/>
  </bus>
  <sim id="sim" width="64" height="48" backend="numpy"><requires interface="pen" from="hub"/>
  </sim>
  <recorder id="rec" output="rec.jsonl"><requires interface="pen" from="hub"/></recorder>
</station>
""")
    plan = resolve(load(str(tmp_path / "bp.xml")), Path("/r"), tmp_path)
    hand, pen = plan.process("hand").argv, plan.process("pen").argv
    assert [hand[i + 1] for i, a in enumerate(hand) if a == "--haptic-bus"] == [
        ">ipc:///r/sim.status"]
    assert "--haptic-bus" not in pen
