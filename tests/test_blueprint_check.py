"""Blueprint checks without running anything: the bundled blueprints validate, and
every broken wiring is refused with exit 2, one line naming the file, line and element."""

from __future__ import annotations

from pathlib import Path

import pytest

from station.blueprint import diagram
from station.blueprint.load import bundled_names, load, loads
from station.blueprint.model import BlueprintError
from station.blueprint.plan import resolve
from station.blueprint.rules import RuleEngine
from station.cli import main

HEAD = '<?xml version="1.0"?>\n<station name="t" version="1">\n'
PEN = '  <driver id="pen" device="mock:intuos-pro-m?script=line"/>\n'
SIM = ('  <sim id="sim" width="64" height="48">\n'
       '    <requires interface="pen" from="pen"/>\n  </sim>\n')


def write(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "bp.xml"
    path.write_text(HEAD + body + "</station>\n")
    return path


def check(path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[int, str]:
    code = main(["blueprint", "check", str(path), *extra])
    err = capsys.readouterr().err
    return code, err


def test_bundled_blueprints_validate(capsys: pytest.CaptureFixture[str]) -> None:
    names = bundled_names()
    assert names == ["headless-demo", "kiosk", "record-only", "two-tablets"]
    for name in names:
        code, err = check(Path(name), capsys)
        assert code == 0, err
        assert "ok (" in err
    kiosk = resolve(load("kiosk"), Path("/r"), Path("/w"))
    assert [p.id for p in kiosk.processes] == ["hub", "kiosk", "tablet"]  # sources last
    # the first pen tablet plugged in, whatever its make (issue 24.2)
    assert kiosk.process("tablet").argv[:3] == ["driver", "--device", "auto:pen"]
    assert len(kiosk.blueprint.rules) == 2


def test_good_blueprint_resolves(tmp_path: Path) -> None:
    plan = resolve(load(str(write(tmp_path, PEN + SIM))), Path("/r"), tmp_path)
    sim, pen = plan.processes
    assert (sim.id, pen.id) == ("sim", "pen")
    assert pen.argv[pen.argv.index("--bus") + 1] == "@ipc:///r/pen.pen"
    assert sim.argv[sim.argv.index("--bus") + 1] == "ipc:///r/pen.pen"
    assert pen.argv[pen.argv.index("--wait-subscribers") + 1] == "1"
    assert "--size" in sim.argv and sim.argv[sim.argv.index("--size") + 1] == "64x48"
    assert sim.recover_argv is not None and "--recover" in sim.recover_argv
    assert "--size" not in sim.recover_argv  # the log says it
    text = diagram.text(plan)
    assert "pen (driver) --pen--> sim (sim)" in text
    assert '"pen" -> "sim" [label="pen"]' in diagram.dot(plan)


BROKEN = [
    ("schema error", PEN + SIM.replace('width="64"', 'width="huge"'), 4, "schema",
     "width"),
    ("unknown element", PEN + '  <scanner id="x"/>\n' + SIM, 4, "schema", "scanner"),
    ("unknown component", PEN + SIM.replace('from="pen"', 'from="pne"'), 5,
     "<requires>", "unknown component 'pne'"),
    ("unsatisfied requirement", PEN + '  <sim id="sim"/>\n', 4, '<sim id="sim">',
     "unsatisfied requirement"),
    ("driver without consumer", PEN + SIM + '  <driver id="extra" device="mock:intuos-pro-m"/>\n',
     7, '<driver id="extra">', "no consumer"),
    ("port clash", PEN + SIM + '  <bus id="hub" pub="ipc:x" sub="ipc:x">\n'
     '    <requires interface="pen" from="two"/>\n  </bus>\n'
     '  <driver id="two" device="mock:cintiq-22hd"/>\n'
     '  <sim id="sim2"><requires interface="pen" from="hub"/></sim>\n', 7, '<bus id="hub">',
     "endpoint clash"),
    ("kiosk port clash", PEN.replace('"/>', '"/>\n') + '  <bus id="hub">\n'
     '    <requires interface="pen" from="pen"/>\n  </bus>\n'
     '  <kiosk id="k1" serve="127.0.0.1:8080"><requires interface="pen" from="hub"/></kiosk>\n'
     '  <kiosk id="k2" serve="0.0.0.0:8080"><requires interface="pen" from="hub"/></kiosk>\n',
     9, '<kiosk id="k2">', "port 8080"),
    ("duplicate id", PEN + SIM + '  <gallery id="pen" dir="g"/>\n', 7, '<gallery id="pen">',
     "duplicate id 'pen' (first at line 3)"),
    ("two pens straight into one sim", PEN + '  <driver id="p2" device="mock:cintiq-22hd"/>\n'
     + SIM.replace("  </sim>", '    <requires interface="pen" from="p2"/>\n  </sim>'), 5,
     '<sim id="sim">', "put a <bus> between"),
    ("wrong interface", PEN + '  <gallery id="g" dir="g"/>\n'
     + SIM.replace('from="pen"', 'from="g"').replace("  </sim>", '    <requires interface='
                                                   '"pen" from="pen"/>\n  </sim>'),
     6, "<requires>", "does not provide 'pen'"),
    ("bad device spec", PEN.replace("mock:", "bogus:") + SIM, 3, '<driver id="pen">',
     "bogus"),
    ("same output file", PEN + SIM.replace('height="48"', 'height="48" png="o.png"')
     + '  <recorder id="rec" output="o.png"><requires interface="pen" from="pen"/>'
     '</recorder>\n', 7, '<recorder id="rec">', "output file clash"),
    ("rule on an unknown component", PEN + SIM + '  <on event="idle" after="2s" '
     'component="nope"><clear/></on>\n', 7, "<on>", "unknown component 'nope'"),
    ("rule action outside the vocabulary", PEN + SIM + '  <on event="idle" after="2s">'
     '<exec cmd="rm -rf /"/></on>\n', 7, "schema", "exec"),
    ("save-to-gallery without a gallery", PEN + SIM + '  <on event="idle" after="2s">'
     '<save-to-gallery/></on>\n', 7, "<save-to-gallery>", "needs a <gallery>"),
    ("not XML", PEN + "  <sim id='sim'>\n", 5, "not well-formed", "sim"),
]


@pytest.mark.parametrize(("case", "body", "line", "element", "needle"), BROKEN,
                         ids=[b[0] for b in BROKEN])
def test_broken_blueprint_exits_2_with_element_and_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str, body: str, line: int,
        element: str, needle: str) -> None:
    path = write(tmp_path, body)
    code, err = check(path, capsys)
    assert code == 2, err
    assert err.count("\n") == 1, err  # one line
    assert f"{path}:{line}:" in err, err
    assert element in err and needle in err, err


def test_overrides(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, PEN + SIM)
    bp = load(str(path), ["sim.width=400", "pen.device=mock:cintiq-22hd?script=arc"])
    plan = resolve(bp, Path("/r"), tmp_path)
    sim = plan.process("sim")
    assert sim.argv[sim.argv.index("--size") + 1] == "400x48"
    assert "mock:cintiq-22hd?script=arc" in plan.process("pen").argv
    for bad, needle in (("sim.width=wide", "after --set sim.width=wide"),
                        ("sim.colour=red", "colour"), ("nobody.width=3", "no component"),
                        ("sim.width", "ID.ATTRIBUTE=VALUE")):
        code, err = check(path, capsys, "--set", bad)
        assert code == 2 and needle in err and err.count("\n") == 1, (bad, err)
    # An empty value removes an attribute: the kiosk's tablet selector becomes a mock.
    kiosk = load("kiosk", ["tablet.vid=", "tablet.pid=", "tablet.device=mock:intuos-pro-m"])
    assert "mock:intuos-pro-m" in resolve(kiosk, Path("/r"), tmp_path).process("tablet").argv


def test_entities_are_not_expanded(tmp_path: Path) -> None:
    """No DTD, no external entity: a blueprint cannot read files through XML."""
    secret = tmp_path / "secret"
    secret.write_text("hunter2")
    doc = (f'<?xml version="1.0"?>\n<!DOCTYPE station [<!ENTITY x SYSTEM "file://{secret}">]>\n'
           '<station name="t" version="1"><description>&x;</description>\n'
           + PEN + SIM + "</station>\n")
    try:
        bp = loads(doc.encode(), "bp.xml")
    except BlueprintError:
        return  # refused outright is fine too
    assert "hunter2" not in bp.description


def test_idle_and_unplug_rules_fire_once_per_period(tmp_path: Path) -> None:
    bp = load(str(write(tmp_path, PEN + SIM + '  <gallery id="g" dir="g"/>\n'
                        '  <on event="idle" after="2s"><save-to-gallery/><clear/></on>\n'
                        '  <on event="device-unplugged" device="pen">'
                        '<show-message text="gone"/></on>\n')))
    eng = RuleEngine(bp.rules, ["sim"])
    assert eng.on_status("sim", {"samples": 0}, 0.0) == []
    assert eng.on_tick(10.0) == []  # never painted: nothing to save
    eng.on_status("sim", {"samples": 5}, 10.0)
    assert eng.on_tick(11.9) == []
    fired = eng.on_tick(12.0)
    assert [f.rule.event for f in fired] == ["idle"] and fired[0].detail["idle_s"] == 2.0
    assert eng.on_tick(20.0) == []  # once per idle period
    eng.on_status("sim", {"samples": 6}, 21.0)
    assert len(eng.on_tick(23.5)) == 1  # the next period
    gone = eng.on_status("sim", {"samples": 6, "silent_devices": ["pen"]}, 24.0)
    assert [(f.rule.event, f.detail) for f in gone] == [("device-unplugged", {"device": "pen"})]
    assert eng.on_status("sim", {"samples": 6, "silent_devices": ["pen"]}, 24.5) == []
    assert eng.on_status("sim", {"samples": 6, "silent_devices": ["other"]}, 25.0) == []


def test_the_documented_example_is_a_working_blueprint(tmp_path: Path) -> None:
    doc = (Path(__file__).parents[1] / "docs" / "blueprint.md").read_text()
    example = doc.split("```xml\n", 1)[1].split("```", 1)[0]
    bp = loads(example.encode(), "docs/blueprint.md")
    plan = resolve(bp, Path("/r"), tmp_path)
    assert [p.id for p in plan.processes] == ["hub", "sim", "left", "right"]
    assert plan.process("right").devices == ["/dev/input/by-id/usb-Wacom_Cintiq-event-stylus"]
    assert [r.event for r in bp.rules] == ["idle", "device-unplugged"]
    assert bp.rules[0].after_s == 300.0


def test_a_restarted_sim_recovers_the_log_it_really_writes(tmp_path: Path) -> None:
    from station.blueprint.supervisor import Supervisor, argv_for

    sim = resolve(load(str(write(tmp_path, PEN + SIM))), Path("/r"), tmp_path).process("sim")
    assert argv_for(sim) == sim.argv  # no log yet: a fresh start
    real = tmp_path / "sessions" / "t-sim-2.jsonl"  # the name was taken: the sim chose -2
    Supervisor._follow_log(sim, str(real))
    real.parent.mkdir()
    real.write_text("{}\n")
    assert argv_for(sim)[-2:] == ["--recover", str(real)]
