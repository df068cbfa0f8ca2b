"""The gallery: saving, the replay animation, the web page in a real headless Chromium."""

from __future__ import annotations

import itertools
import shutil
import subprocess
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from station.canvas.palette import default_palette
from station.events import Command, PenSample, Tool
from station.kiosk.gallery import (
    Gallery,
    GalleryServer,
    export_replay,
    new_id,
    painting_url,
    qr_matrix,
)
from station.render.km import to_srgb8
from station.sessionlog import SessionHeader, SessionLogWriter
from station.sim.paint import make_backend
from station.sim.player import SessionPlayer

W, H = 160, 120


def write_log(path: Path) -> None:
    """A short session: a Phthalo Green stroke across the canvas, then a wait."""
    with SessionLogWriter(path, SessionHeader(width=W, height=H, extra={"sim": {"rate": 30.0}})
                          ) as w:
        w.write(Command(t=0.0, cmd="brush", args={"size": 14, "water": 0.9,
                                                   "pigment": {"Phthalo Green": 0.8}}))
        for i in range(40):
            w.write(PenSample(t=0.1 + i * 0.02, device="pen", tool=Tool.PEN, x=0.15 + 0.018 * i,
                              y=0.5, pressure=0.8, touching=True))
        w.write(PenSample(t=0.92, device="pen", tool=Tool.PEN, x=0.85, y=0.5, proximity=False))
        w.write(Command(t=1.0, cmd="wait", args={"seconds": 1.0}))


def painted_image(log: Path) -> np.ndarray:
    """What ``station paint`` makes of the log (same player, same backend)."""
    from station.sessionlog import read_session

    _header, records = read_session(log)
    canvas, _ = make_backend("auto", W, H, "watercolor", 0)
    player = SessionPlayer(canvas, W, H, "watercolor", rate=30.0, pigments=default_palette())
    player.play(records)
    return to_srgb8(canvas.render())


def saved_painting(tmp_path: Path) -> tuple[Gallery, str, Path, np.ndarray]:
    """A gallery holding the test log's painting: the gallery, its id, the log, the image."""
    log = tmp_path / "s.jsonl"
    write_log(log)
    painting = painted_image(log)
    g = Gallery(tmp_path / "gallery")
    pid = new_id()
    g.save(pid, painting, log, {"width": W, "height": H, "profile": "watercolor"})
    return g, pid, log, painting


def green(img: np.ndarray) -> np.ndarray:
    img = img.astype(int)
    return (img[..., 1] - img[..., 0] > 20) & (img[..., 2] - img[..., 0] > 10)


def test_replay_animation_ends_on_the_painting(tmp_path: Path) -> None:
    log = tmp_path / "s.jsonl"
    write_log(log)
    out = tmp_path / "replay.webp"
    n = export_replay(log, out, frames=12, width=W)
    anim = Image.open(out)
    assert anim.format == "WEBP" and anim.n_frames == n >= 10
    frames = []
    for k in range(anim.n_frames):
        anim.seek(k)
        frames.append(np.asarray(anim.convert("RGB")).astype(int))
    painting = painted_image(log)
    # the stroke grows frame by frame while the pen moves (the first ~0.9 s of 2 s), then
    # the wash only settles: green area within a few per cent of the painting's
    counts = [int(green(f).sum()) for f in frames]
    assert counts[0] == 0 and counts[-1] > 300
    moving = counts[:len(counts) // 2]
    assert all(b > a + 100 for a, b in itertools.pairwise(moving)), counts
    assert all(abs(c - counts[-1]) < 0.06 * counts[-1] for c in counts[len(counts) // 2 + 1:])
    # the last frame is the painting: compared pixel by pixel (a count of "green" pixels
    # moves with WebP's chroma subsampling at the stroke's saturated edge)
    assert np.abs(frames[-1] - painting.astype(int)).mean() < 4  # lossy WebP of the same image
    gif = tmp_path / "replay.gif"
    assert export_replay(log, gif, frames=6, width=80) >= 6
    assert Image.open(gif).n_frames >= 6


def test_ids_are_checked_before_touching_the_disk(tmp_path: Path) -> None:
    g = Gallery(tmp_path / "g")
    from station.errors import BadInput

    for bad in ("../x", "20261124-000000-zzzzzz", "", "20261124-000000-abcdef/.."):
        with pytest.raises(BadInput):
            g.path(bad)


def test_qr_matrix_decodes_to_the_url() -> None:
    import zxingcpp

    url = "http://192.168.1.20:8080/p/20261124-101500-a1b2c3"
    m = qr_matrix(url)
    img = np.where(m > 0, 0, 255).astype(np.uint8).repeat(6, 0).repeat(6, 1)
    assert [r.text for r in zxingcpp.read_barcodes(Image.fromarray(img))] == [url]


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser") or \
        shutil.which("google-chrome")


@pytest.mark.skipif(chromium() is None, reason="no Chromium (apt-get install chromium)")
def test_gallery_page_in_headless_chromium(tmp_path: Path) -> None:
    """The take-home page on a phone, a tablet and a laptop: the painting at its own
    aspect (within 1 %) at 390, 768 and 1280 px wide, never wider than the screen,
    and no QR code on the page the kiosk's QR code points to."""
    import zxingcpp

    g, pid, log, painting = saved_painting(tmp_path)
    # an 800x600 painting (the kiosk's canvas): a red field in a dark frame
    big = np.zeros((600, 800, 3), np.uint8)
    big[...] = (30, 30, 30)
    big[4:-4, 4:-4] = (220, 40, 30)
    big_id = new_id()
    g.save(big_id, big, log, {"width": 800, "height": 600, "profile": "watercolor"})
    server = GalleryServer(g, "127.0.0.1", 0).start()
    try:
        base = f"http://127.0.0.1:{server.port}"
        for width in (390, 768, 1280):
            shot = tmp_path / f"page-{width}.png"
            proc = subprocess.run(
                [str(chromium()), "--headless=new", "--no-sandbox", "--disable-gpu",
                 "--hide-scrollbars", "--force-device-scale-factor=1",
                 f"--window-size={width},1100", f"--screenshot={shot}",
                 painting_url(base, big_id)],
                capture_output=True, text=True, timeout=90)
            assert shot.exists(), proc.stderr[-2000:]
            page = np.asarray(Image.open(shot).convert("RGB")).astype(int)
            assert page.shape[1] == width
            red = (page[..., 0] > 180) & (page[..., 1] < 90) & (page[..., 2] < 90)
            ys, xs = np.nonzero(red)
            # the red field is 792x592 of the 800x600 painting: its aspect, within 1 %
            shown = (np.ptp(xs) + 1) / (np.ptp(ys) + 1)
            assert abs(shown / (792 / 592) - 1) < 0.01, (width, shown)
            assert xs.max() < width  # never wider than the screen
            assert np.ptp(xs) + 1 >= min(792, 0.8 * width)  # and not a thumbnail
            assert zxingcpp.read_barcodes(Image.fromarray(page.astype(np.uint8))) == []
        # the small painting at its own size, pixel for pixel, at a laptop's width
        shot = tmp_path / "page.png"
        subprocess.run(
            [str(chromium()), "--headless=new", "--no-sandbox", "--disable-gpu",
             "--hide-scrollbars", "--force-device-scale-factor=1", "--window-size=800,600",
             f"--screenshot={shot}", painting_url(base, pid)],
            capture_output=True, text=True, timeout=90)
        page = np.asarray(Image.open(shot).convert("RGB"))
        button = np.nonzero((np.abs(page.astype(int) - (45, 93, 138)).sum(-1) < 6).any(1))[0]
        page = page[:button.min()]  # the painting, above the (blue) download buttons
        assert abs(int(green(page).sum()) - int(green(painting).sum())) <= 5
        ys, xs = np.nonzero(green(page))
        top, left = ys.min() - np.nonzero(green(painting))[0].min(), \
            xs.min() - np.nonzero(green(painting))[1].min()
        assert np.abs(page[top:top + H, left:left + W].astype(int) - painting).max() <= 2
        # nothing outside the painting's own files
        for bad in ("/p/../../etc/passwd", "/p/20261124-000000-abcdef", f"/p/{pid}/meta.py",
                    f"/p/{pid}/..%2f..%2fs.jsonl", f"/p/{pid}/session.jsonl", "/"):
            with pytest.raises(urllib.error.HTTPError) as exc:
                urllib.request.urlopen(base + bad, timeout=10)
            assert exc.value.code == 404, bad
    finally:
        server.stop()


def test_gallery_make_writes_the_replay_and_a_print_in_a_low_priority_process(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import json
    import os

    from station.kiosk.gallery import MAKE_LOG, PRINT, REPLAY

    g, pid, log, painting = saved_painting(tmp_path)
    proc = g.prepare(pid)  # what the kiosk starts when it saves
    # a cold numba cache compiles the cpu kernels first (3.8 min alone here): the generous
    # deadline, within the test timeout of 300 s
    assert proc.wait(280) == 0, g.path(pid, MAKE_LOG).read_text()[-2000:]
    assert g.path(pid, REPLAY).exists()
    big = np.asarray(Image.open(g.path(pid, PRINT)).convert("RGB"))
    assert big.shape == (2 * H, 2 * W, 3)
    # the print is the painting at 2 px a cell: halved, it is the painting to a few levels
    small = big.reshape(H, 2, W, 2, 3).astype(float).mean(axis=(1, 3))
    assert np.abs(small - painting).mean() < 3.0
    assert green(big).sum() > 3.5 * green(painting).sum()
    # its priority: the command lowers its own before it replays
    from station.cli import main
    from station.kiosk import gallery as gallery_mod

    calls: list[str] = []
    monkeypatch.setattr(os, "nice", lambda n: calls.append(f"nice {n}") or 0)
    monkeypatch.setattr(gallery_mod.Gallery, "make",
                        lambda self, pid: calls.append(f"make {pid}") or [])
    assert main(["gallery", "make", "--root", str(g.root), pid]) == 0
    assert calls == ["nice 19", f"make {pid}"]
    monkeypatch.undo()
    # the page offers the print as a download at 2x; a re-save makes it stale, and the
    # server's worker makes it again when it is asked for (503 meanwhile, never a wait)
    server = GalleryServer(g, "127.0.0.1", 0).start()
    try:
        base = f"http://127.0.0.1:{server.port}/p/{pid}"
        with urllib.request.urlopen(base, timeout=30) as r:
            page = r.read().decode()
        assert f'href="/p/{pid}/{PRINT}" download=' in page and f"{2 * W}×{2 * H}" in page
        with urllib.request.urlopen(f"{base}/{PRINT}", timeout=30) as r:
            assert r.read() == g.path(pid, PRINT).read_bytes()
        g.save(pid, painting, log, json.loads(g.path(pid, "meta.json").read_text()))
        assert not g.path(pid, PRINT).exists() and not g.path(pid, REPLAY).exists()
        with pytest.raises(urllib.error.HTTPError) as exc:
            urllib.request.urlopen(f"{base}/{PRINT}", timeout=30)
        assert exc.value.code == 503 and exc.value.headers["Retry-After"]
    finally:
        server.stop()


def test_gallery_command_refuses_bad_input(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    from station.cli import main

    for argv, where in ((["make", "not-an-id"], "not-an-id"),
                        (["make", "--root", str(tmp_path), "20261124-101500-a1b2c3"], "ID"),
                        (["make", "--nice", "40", "20261124-101500-a1b2c3"], "--nice"),
                        (["serve", "--serve", "nowhere"], "--serve")):
        assert main(["gallery", *argv]) == 2, argv
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and where in err, err
