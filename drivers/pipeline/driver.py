"""The driver loop: one pen source through a normaliser, and paced round-robin runs."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

from station.drivers.normalise import Normaliser, NormaliserConfig
from station.drivers.pipeline.sources import PenSource
from station.drivers.transport.base import DeviceGone

from station.events import PenSample
from station.stopsignal import StopFlag


class PenDriver:
    """Runs one source through a normaliser; samples go to ``sink``.

    ``poll`` does one read (with timeout) and returns the samples it produced,
    forcing proximity-out on the source's clock when nothing came.
    """

    def __init__(self, source: PenSource, config: NormaliserConfig | None = None,
                 transform: Callable[[PenSample], PenSample] | None = None,
                 on_device_sample: Callable[[PenSample], None] | None = None,
                 origin: float | None = None, live: bool = False,
                 t_offset: float = 0.0) -> None:
        self.source = source
        self.live = live
        self.normaliser = Normaliser(source.ranges, device=source.name, config=config,
                                     origin=origin, transform=transform,
                                     on_device_sample=on_device_sample, t_offset=t_offset)

    def poll(self, timeout: float | None = 0.01) -> list[PenSample]:
        raws = self.source.read_raw(timeout)
        if not raws:
            return self.normaliser.tick(self.source.now())
        out: list[PenSample] = []
        t_mono = time.monotonic() if self.live else 0.0
        for raw in raws:
            out.extend(self.normaliser.feed(raw, t_mono))
        return out

    def samples(self) -> Iterator[PenSample]:
        """Every sample until the source ends (or is removed); then closes the source."""
        try:
            while True:
                yield from self.poll(0.05)
        except DeviceGone:
            yield from self.normaliser.flush()
        finally:
            self.source.close()

    def status(self) -> dict[str, object]:
        n = self.normaliser.stats
        src = self.source.describe()
        stats = getattr(self.source, "stats", None)
        parser = getattr(self.source, "parser", None)
        return {
            **src,
            "reports": getattr(stats, "reports", 0),
            "bad_reports": getattr(stats, "bad_reports", 0),
            "bad_reasons": dict(getattr(stats, "bad_reasons", {})),
            "skipped_reports": getattr(parser, "skipped", 0) if parser is not None else 0,
            # skipped reports by report ID (decimal) and by kind (touch, pad, unused …)
            "skipped_by_id": {str(k): v for k, v in sorted(
                getattr(parser, "skipped_by_id", {}).items())},
            "skipped_by_kind": dict(sorted(getattr(parser, "skipped_by_kind", {}).items())),
            "parser_dropped": getattr(parser, "dropped", 0) if parser is not None else 0,
            "long_reports": getattr(parser, "long_reports", 0) if parser is not None else 0,
            "samples": n.samples,
            "rejected_samples": n.rejected,
            "forced_proximity_out": n.forced_out,
            "nib_offsets": n.nib_offsets,
            "in_proximity": self.normaliser.in_proximity,
        }



def run_paced(drivers: list[PenDriver], emit: Callable[[PenSample], None],
              stop: StopFlag | None = None,
              idle: Callable[[], None] | None = None) -> None:
    """Run paced drivers (speed set on their transports) round-robin until all end.

    ``idle`` is called after every poll, samples or not (at least every 0.05 s),
    so the caller can send heartbeats while the recording waits."""
    active = list(drivers)
    while active and not (stop and stop.is_set()):
        for drv in list(active):
            try:
                for sample in drv.poll(0.002 if len(active) > 1 else 0.05):
                    emit(sample)
            except DeviceGone:
                for sample in drv.normaliser.flush():
                    emit(sample)
                active.remove(drv)
            if idle is not None:
                idle()

