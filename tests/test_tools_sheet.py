"""The tools sheet's bundled session: current, and every command in it is executed."""

from __future__ import annotations

from station.events import Command
from station.pictures.tools_sheet import bundled_session, session_lines
from station.sessionlog import read_session
from station.sim.player import check_command


def test_bundled_session_is_the_generated_one_and_fully_executed() -> None:
    path = bundled_session()
    assert path.read_text().splitlines() == session_lines()
    header, records = read_session(path)
    cmds = [r for r in records if isinstance(r, Command)]
    for c in cmds:
        check_command(c)  # raises for a command nothing would execute
    names = {c.cmd for c in cmds}
    assert {"mask", "mask_remove", "tissue", "eraser", "diffusion", "well", "tilt"} <= names
    assert (header.width, header.height) == (480, 320)
