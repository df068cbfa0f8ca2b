"""The settings of one ``station kiosk`` run, the loop's pace and numba's threading check."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from station.kiosk.gallery import (
    WebOptions,
)
from station.kiosk.idle import IdleConfig

DRIVER_SILENT_S = 5.0  # a driver that said nothing this long is taken as gone
STATUS_EVERY_S = 0.5
REDRAW_EVERY_S = 0.25  # a quiet kiosk still redraws this often (status line, banners)
AUTO_HORIZON_START_S = 0.008  # the auto prediction's horizon until frames measured it
TILE_FRAME_S = 1 / 120  # frames that show only the steps' tiles come at most this often
LATCH_BUDGET_S = 0.002  # the late latch handles pen samples for at most this long
THREAD_POLL_S = 0.004  # a wet canvas: how often the window looks for the thread's steps
ATTRACT_FRAME_S = 1 / 12  # the attract screen's animation: frames this often
# Python's full garbage collections: never in the middle of a stroke (one walks every
# object the process holds: 120 ms for a kiosk's 190 000 at load 8, a visible hitch)
# but while the pen is off the paper this long, at most this often, and at least this
# often whatever the pen does (cyclic garbage cannot pile up without bound)
GC_PEN_UP_S = 1.5
GC_EVERY_S = 60.0
GC_AT_LEAST_S = 600.0
#: The third generation's threshold while the kiosk collects it itself (Python's default
#: is 10: a full collection whenever the survivors grew by a quarter).
GC_GEN2_THRESHOLD = 1_000_000


@dataclass
class KioskConfig:
    """Settings of one ``station kiosk`` run."""

    bus: str | None = None
    width: int = 800
    height: int = 600
    profile: str = "watercolor"
    backend: str = "auto"
    seed: int = 0
    rate: float | None = None
    fullscreen: bool = True
    monitor: int = 0
    window: tuple[int, int] = (1024, 768)
    gallery: Path = Path("gallery")
    # HOST:PORT of the gallery web page (loopback unless the operator names the kiosk's
    # address); None: no server.  web: what it serves and its limits.
    serve: str | None = "127.0.0.1:8080"
    web: WebOptions = field(default_factory=WebOptions)
    base_url: str | None = None  # what QR codes point to (default: this machine's address)
    idle: IdleConfig = field(default_factory=IdleConfig)
    status: str | None = None  # status endpoint; "none" disables
    duration: float | None = None
    screenshot_dir: Path | None = None
    view: str = "2d"
    vsync: bool = True
    panel_fraction: float = 0.3
    cmd: str | None = None  # where `station send` reaches the kiosk; "none" disables
    autosave: float = 30.0  # seconds between autosaves of the painting (0: off)
    sim_thread: bool = True  # steps in a thread of their own (False: in the frame loop)
    # how much lower the simulation thread's priority is than the window's (nice steps):
    # on a busy machine the pen is shown first and the steps wait (0: the same)
    sim_nice: int = 5
    # the pen shadow drawn this far ahead of the last sample (0: off; None: auto, the
    # window's own measured pen-to-screen lag, station.kiosk.predict.LagEstimate)
    predict_ms: float | None = None
    present: str = "auto"  # auto, swap, partial (station.kiosk.present)
    # what paints besides a pen driver on the bus: the window's mouse/touchscreen
    # ("auto": yes, unless a pen was heard in the last second; "pen": no; "mouse": yes)
    input: str = "auto"
    mouse_pressure: float | None = None  # the mouse's pressure (None: from its speed)
    keys: Path | None = None  # CURVE key directory for tcp endpoints (None: the default)
    client_key: str | None = None  # a client key pair of its own for connecting over tcp


def numba_threadsafe() -> bool:
    """Whether numba's threading layer lets two threads launch parallel kernels at once
    (``omp``, ``tbb``; the fallback ``workqueue`` aborts the process if they do)."""
    try:
        import numba
        from numba.np.ufunc import parallel

        parallel._launch_threads()
        return str(numba.threading_layer()) in ("omp", "tbb")
    except Exception:  # an unknown numba: assume the worst
        return False
