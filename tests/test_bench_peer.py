"""``station bench peer`` (issue 26 item 2): how to install the peer when it is missing,
and the interleaved comparison's bookkeeping, run against a stand-in peer (a module
named ``taichi`` and an engine with the peer's interface whose step takes a known time:
the real one needs taichi from the registry)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from station.bench import peer
from station.cli import main

FAKE_TAICHI = """
cpu = "cpu"
def init(**kwargs):
    pass
def sync():
    pass
"""

FAKE_ENGINE = """
import time
class WatercolorEngine:
    def __init__(self, res, arch="cpu"):
        self.res = res
    def clear(self):
        pass
    def paint_mask(self, p, w):
        assert p.shape == (self.res, self.res)
    def paint_brush(self, x, y, r, brush_id=0, dryness=0.5):
        assert 0 <= x < self.res and 0 <= y < self.res
    def step(self, steps=1):
        time.sleep(0.002)
"""


def _fake_peer(root: Path) -> Path:
    src = root / "src"
    pkg = src / "open_watercolor_sim" / "brush"
    pkg.mkdir(parents=True)
    (src / "open_watercolor_sim" / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "watercolor_engine.py").write_text(FAKE_ENGINE)
    (src / "taichi.py").write_text(FAKE_TAICHI)
    return src


def test_without_the_peer_it_says_how_to_install_it(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
    assert main(["bench", "peer", "--peer-src", str(tmp_path)]) == 1
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    assert "not the peer's src" in out["error"]
    assert "pip install taichi" in out["how_to_install"]
    assert peer.PEER_REPO in out["how_to_install"] and peer.PEER_REPO in cap.err
    assert main(["bench", "peer", "--sizes", "12"]) == 2  # bad input: one line, exit 2


def test_a_pair_and_its_ratio(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    src = _fake_peer(tmp_path)
    monkeypatch.setenv("PYTHONPATH", str(src))  # the stand-in taichi for the import check
    assert peer.peer_problem(peer.sys.executable, src) is None
    # one real station child (a second pair would double the test's time, not its reach)
    out = peer.compare([64], 1, 5, 1, peer.sys.executable, src)
    assert out["pairs"] == 1 and len(out["load_average_before"]) == 3
    assert {r["scenario"] for r in out["results"]} == {"wash", "stroke"}
    for r in out["results"]:
        assert r["size"] == "64x64"
        assert len(r["station_steps_per_s"]) == len(r["peer_steps_per_s"]) == 1
        # the stand-in sleeps 2 ms a step: at most 500 steps/s
        assert all(0 < v <= 500 for v in r["peer_steps_per_s"])
        ratios = [a / b for a, b in zip(r["station_steps_per_s"], r["peer_steps_per_s"],
                                        strict=True)]
        assert r["median_ratio"] == pytest.approx(ratios[0], rel=1e-2)
        assert r["median_sim_time_ratio"] == pytest.approx(2 * r["median_ratio"], rel=1e-2)
