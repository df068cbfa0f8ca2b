"""Wacom tool ids (the 'tool id' of an Intuos proximity packet) and their tool types.

Ids from the public Linux wacom driver's table; any id not listed is an
eraser when bit 0x0008 is set, else a pen (the kernel's default).
"""

from __future__ import annotations

from station.events import Tool

STYLUS_DEVICE_ID = 0x02  # tool id the kernel reports for protocols without ids (Bamboo, Graphire)
ERASER_DEVICE_ID = 0x0A
CURSOR_DEVICE_ID = 0x06

GRIP_PEN = 0x10802
ART_PEN = 0x10804

_TOOL_IDS: dict[int, Tool] = {}


def _add(tool: Tool, *ids: int) -> None:
    for i in ids:
        _TOOL_IDS[i] = tool


_add(Tool.PENCIL, 0x812, 0x801, 0x12802, 0x012)
_add(Tool.PEN, 0x822, 0x842, 0x852, 0x823, 0x813, 0x802, 0x8E2, 0x022, 0x200, 0x4200,
     0x10842, 0x14802, 0x16802, 0x18802, 0x10802, 0x80842, 0x804, 0x10804)
_add(Tool.BRUSH, 0x832, 0x032)
_add(Tool.MOUSE, 0x007, 0x09C, 0x094, 0x017, 0x806)
_add(Tool.LENS, 0x096, 0x097, 0x006)
_add(Tool.ERASER, 0x82A, 0x84A, 0x85A, 0x91A, 0xD1A, 0x0FA, 0x82B, 0x81B, 0x91B, 0x80C, 0x80A,
     0x90A, 0x1480A, 0x1090A, 0x1080C, 0x1084A, 0x1680A, 0x1880A, 0x1080A)
_add(Tool.AIRBRUSH, 0xD12, 0x912, 0x112, 0x913, 0x902, 0x10902)


def tool_from_id(tool_id: int) -> Tool:
    """The tool type of a Wacom tool id."""
    tool = _TOOL_IDS.get(tool_id)
    if tool is not None:
        return tool
    return Tool.ERASER if tool_id & 0x0008 else Tool.PEN


def known_tool_ids() -> dict[int, Tool]:
    """A copy of the explicit table (for docs and tests)."""
    return dict(_TOOL_IDS)
