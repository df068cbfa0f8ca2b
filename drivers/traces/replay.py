"""A trace played through the driver pipeline's normaliser: :func:`iter_trace_samples`.

It lives beside the readers rather than in ``station.drivers.traces`` itself because the
pipeline's replay imports the readers: a package ``__init__`` that imported the pipeline
would close a circle.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

from station.drivers.normalise import NormaliserConfig
from station.drivers.pipeline import TraceReplay
from station.drivers.traces import read_trace

from station.errors import BadInput
from station.events import PenSample


def iter_trace_samples(path: str | os.PathLike[str], device: str | None = None,
                       config: NormaliserConfig | None = None) -> Iterator[PenSample]:
    """Pen samples of every pen device in the trace, in time order.

    Device-normalised unless ``config`` names a canvas to map them onto.  A
    trace without a pen device raises :class:`~station.errors.BadInput`.
    """
    replay = TraceReplay(read_trace(path), config=config, device_name=device)
    if not replay.pen_devices:
        raise BadInput(f"no pen device in this trace ({replay.skipped_text()})", str(path))
    yield from replay.samples()
