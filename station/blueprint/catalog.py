"""What each component kind provides and requires (the dissertation's prototypes).

A kind is a prototype: the blueprint instantiates it with an id and attributes
and wires its required interfaces to other components' provided ones.

=========== ============ ================================ ==================
kind        provides     requires (min..max)              process
=========== ============ ================================ ==================
bus         pen          pen 1..n                         ``station bus``
driver      pen          calibration 0..1                 ``station driver``
haptic      pen          calibration 0..1                 ``station driver`` (serial SPEC)
replay      pen          –                                ``station replay``
sim         –            pen 1..1                         ``station sim``
kiosk       –            pen 1..1, gallery 0..1           ``station kiosk``
recorder    –            pen 1..1                         ``station record --bus``
gallery     gallery      –                                none (a directory)
calibration calibration  –                                none (a file)
=========== ============ ================================ ==================
"""

from __future__ import annotations

from dataclasses import dataclass, field

UNBOUNDED = 1 << 30


@dataclass(frozen=True)
class Kind:
    """A component prototype: interfaces and whether it runs as a process."""

    name: str
    provides: tuple[str, ...] = ()
    requires: dict[str, tuple[int, int]] = field(default_factory=dict)
    process: bool = True
    source: bool = False  # publishes pen samples of its own
    paints: bool = False  # holds a canvas (rules act on it)


KINDS: dict[str, Kind] = {k.name: k for k in (
    Kind("bus", provides=("pen",), requires={"pen": (1, UNBOUNDED)}),
    Kind("driver", provides=("pen",), requires={"calibration": (0, 1)}, source=True),
    Kind("haptic", provides=("pen",), requires={"calibration": (0, 1)}, source=True),
    Kind("replay", provides=("pen",), source=True),
    Kind("sim", requires={"pen": (1, 1)}, paints=True),
    Kind("kiosk", requires={"pen": (1, 1), "gallery": (0, 1)}, paints=True),
    Kind("recorder", requires={"pen": (1, 1)}),
    Kind("gallery", provides=("gallery",), process=False),
    Kind("calibration", provides=("calibration",), process=False),
)}
