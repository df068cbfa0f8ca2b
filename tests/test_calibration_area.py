"""Areas composed into one matrix, pressure/tilt calibration, and Calibration.apply."""

from __future__ import annotations

import numpy as np
import pytest
from station.calibration.area import (
    Area,
    AreaMapper,
    AreaSettings,
    DeviceGeometry,
    Rect,
    area_matrix,
)
from station.calibration.errors import CalibrationError, OutsideArea
from station.calibration.model import Calibration, DeviceId, FitInfo
from station.calibration.pressure import (
    PressureSettings,
    TiltSettings,
    bezier_eval,
    fit_curve,
    threshold_and_maximum,
    tilt_offset,
)

from station.events import PenSample, Tool

INTUOS = DeviceGeometry(0, 44704, 0, 27940, 200.0, 200.0)  # 223.5 × 139.7 mm
DEV = DeviceId(0x056A, 0x0315)


def mapper(**kw: object) -> AreaMapper:
    return AreaMapper(AreaSettings(**kw), INTUOS)


def mm(x: float, y: float) -> np.ndarray:
    """A tablet position in mm → device-normalised."""
    return np.array([[x * 200 / 44704, y * 200 / 27940]])


def test_whole_tablet_is_identity_exactly() -> None:
    m = mapper()
    assert np.array_equal(m.matrix, np.eye(3))


def test_area_in_mm_maps_corners_to_output_corners() -> None:
    # a 100 × 60 mm area centred at (80, 50) mm
    m = mapper(area=Area(80, 50, 100, 60, 0.0, "mm"))
    for (x, y), want in (((30, 20), (0, 0)), ((130, 20), (1, 0)), ((130, 80), (1, 1)),
                         ((80, 50), (0.5, 0.5))):
        got, inside = m.map(mm(x, y))
        assert np.allclose(got[0], want, atol=1e-12) and inside[0]


def test_area_in_device_units_equals_the_same_area_in_mm() -> None:
    a = mapper(area=Area(80, 50, 100, 60, 0.0, "mm")).matrix
    b = mapper(area=Area(16000, 10000, 20000, 12000, 0.0, "device")).matrix
    assert np.allclose(a, b, atol=1e-12)


@pytest.mark.parametrize("rot, corner", [(90, (0, 1)), (180, (1, 1)), (270, (1, 0))])
def test_quarter_rotations_move_the_top_left_corner(rot: int, corner: tuple[int, int]) -> None:
    # A square area turned 90° clockwise on the tablet (OpenTabletDriver's sense): the
    # area's own top-left sits at the tablet's top-right, so the tablet's top-left corner
    # is the area's bottom-left.  (A tablet the user turns 90° clockwise, xsetwacom's
    # "Rotate cw", needs the area turned the other way: 270.)
    m = mapper(area=Area(70, 70, 100, 100, float(rot), "mm"))
    got, _ = m.map(mm(20, 20))
    assert np.allclose(got[0], corner, atol=1e-12)


def test_free_rotation_is_a_rotation() -> None:
    m = mapper(area=Area(70, 70, 100, 100, 30.0, "mm"))
    a, _ = m.map(mm(70, 70))
    b, _ = m.map(mm(70 + 40 * np.cos(np.radians(30)), 70 + 40 * np.sin(np.radians(30))))
    assert np.allclose(a[0], (0.5, 0.5)) and np.allclose(b[0], (0.9, 0.5), atol=1e-12)


def test_left_handed_is_half_a_turn() -> None:
    lh = mapper(left_handed=True)
    got, _ = lh.map(np.array([[0.1, 0.2], [0.5, 0.5]]))
    assert np.allclose(got, [[0.9, 0.8], [0.5, 0.5]], atol=1e-12)


def test_aspect_lock_shrinks_area_to_output_shape() -> None:
    # whole tablet 223.5 × 139.7 mm (1.6) onto a 4:3 screen: width shrinks to 186.27 mm
    m = mapper(lock_aspect=True, output_pixels=(1024, 768))
    left, _ = m.map(mm((223.52 - 139.7 * 4 / 3) / 2, 0))
    right, _ = m.map(mm((223.52 + 139.7 * 4 / 3) / 2, 139.7))
    assert np.allclose(left[0], (0, 0), atol=1e-9) and np.allclose(right[0], (1, 1), atol=1e-9)
    # equal physical strokes give equal pixel lengths in x and y
    a, _ = m.map(mm(100, 60))
    bx, _ = m.map(mm(110, 60))
    by, _ = m.map(mm(100, 70))
    assert (bx[0, 0] - a[0, 0]) * 1024 == pytest.approx((by[0, 1] - a[0, 1]) * 768)


def test_output_subrect_and_clip_or_drop() -> None:
    m = mapper(area=Area(80, 50, 100, 60, 0.0, "mm"), output=Rect(0.25, 0.5, 0.5, 0.25))
    got, inside = m.map(np.vstack([mm(80, 50), mm(130, 80), mm(200, 10)]))
    assert np.allclose(got[0], (0.5, 0.625)) and np.allclose(got[1], (0.75, 0.75))
    assert inside.tolist() == [True, True, False]
    assert np.allclose(got[2], (0.75, 0.5))  # clipped onto the output's edge


def test_matrix_rebuilt_only_when_a_setting_changes() -> None:
    m = mapper(area=Area(80, 50, 100, 60, 0.0, "mm"))
    first = m.matrix
    for _ in range(100):
        m.map(mm(50, 50))
        m.set(left_handed=False)  # same value: no rebuild
    assert m.rebuilds == 1
    m.set(left_handed=True)
    assert m.rebuilds == 1  # lazily, on the next use
    assert not np.array_equal(m.matrix, first) and m.rebuilds == 2
    m.set_fit(np.eye(3))
    _ = m.matrix
    assert m.rebuilds == 2


def test_settings_are_validated() -> None:
    with pytest.raises(CalibrationError):
        AreaSettings(outside="wrap")
    with pytest.raises(CalibrationError):
        AreaSettings(output=Rect(0.5, 0.5, 0.6, 0.2))
    with pytest.raises(CalibrationError):
        AreaSettings(lock_aspect=True)
    with pytest.raises(CalibrationError, match="no resolution"):
        area_matrix(AreaSettings(area=Area(1, 1, 2, 2, units="mm")), DeviceGeometry(0, 100, 0, 100))


# -- pressure and tilt ---------------------------------------------------------------------


def test_bezier_linear_and_monotonic() -> None:
    x = np.linspace(0, 1, 101)
    assert np.allclose(bezier_eval((0.0, 0.0, 1.0, 1.0), x), x, atol=1e-9)
    soft = bezier_eval((0.1, 0.6, 0.4, 1.0), x)
    assert (np.diff(soft) >= -1e-12).all() and (soft >= x - 1e-9).all()
    assert soft[0] == pytest.approx(0) and soft[-1] == pytest.approx(1)


def test_curve_fit_recovers_known_control_points() -> None:
    truth = (0.25, 0.05, 0.6, 0.9)
    x = np.linspace(0.05, 0.95, 12)
    y = bezier_eval(truth, x)
    got = fit_curve(x.tolist(), y.tolist())
    fine = np.linspace(0, 1, 201)
    assert np.abs(bezier_eval(got, fine) - bezier_eval(truth, fine)).max() < 2e-3
    with pytest.raises(CalibrationError):
        fit_curve([0.5], [0.5])
    with pytest.raises(CalibrationError):
        fit_curve([0.2, 0.5], [0.1, 1.5])


def test_threshold_and_maximum_from_light_and_hard_press() -> None:
    rng = np.random.default_rng(0)
    light = np.clip(rng.normal(0.08, 0.01, 60), 0, 1)
    hard = np.clip(rng.normal(0.7, 0.05, 60), 0, 1)
    thr, top = threshold_and_maximum([0.0, *light], hard)
    assert thr == pytest.approx(0.04, abs=0.005)
    assert top == pytest.approx(0.7 + 1.2816 * 0.05, abs=0.02)
    ps = PressureSettings(thr, top)
    assert ps.map_one(thr * 0.9) == 0.0 and ps.map_one(top) == 1.0 and ps.map_one(0.99) == 1.0
    with pytest.raises(CalibrationError, match="harder"):
        threshold_and_maximum(hard, light)


def test_tilt_offset_from_upright_samples() -> None:
    t = tilt_offset([(2.0, -3.0), (2.5, -2.5), (1.5, -3.5)])
    assert (t.offset_x, t.offset_y) == pytest.approx((2.0, -3.0))
    assert t.correct(2.0, -3.0) == (0.0, 0.0)
    assert t.correct(89.0, 0.0) == (87.0, 3.0)


# -- Calibration.apply ---------------------------------------------------------------------


def sample(x: float, y: float, **kw: object) -> PenSample:
    base: dict[str, object] = {"t": 1.0, "device": "pen-0", "tool": Tool.PEN, "x": x, "y": y,
                               "pressure": 0.5, "touching": True}
    base.update(kw)
    return PenSample(**base)  # type: ignore[arg-type]


def test_apply_maps_position_pressure_tilt_and_parallax() -> None:
    fit = FitInfo("affine", ((0.9, 0.0, 0.05), (0.0, 0.8, 0.1), (0, 0, 1)), (0.01, -0.02))
    cal = Calibration(DEV, INTUOS, fit, pressure=PressureSettings(0.1, 0.9, (0.0, 0.0, 1.0, 1.0)),
                      tilt=TiltSettings(5.0, 0.0))
    out = cal.apply(sample(0.5, 0.5, tilt_x=50.0, tilt_y=-45.0, pressure=0.5))
    # tilt offset first (50 → 45), then parallax by tan(45°) = 1, then the matrix
    assert out.tilt_x == pytest.approx(45.0) and out.tilt_y == pytest.approx(-45.0)
    assert out.x == pytest.approx(0.9 * (0.5 + 0.01) + 0.05)
    assert out.y == pytest.approx(0.8 * (0.5 + 0.02) + 0.1)
    assert out.pressure == pytest.approx(0.5)  # (0.5 - 0.1) / 0.8
    light = cal.apply(sample(0.5, 0.5, pressure=0.05))
    assert light.touching is False and light.pressure == 0.0
    assert out.t == 1.0 and out.device == "pen-0"


def test_apply_clip_or_drop_outside_the_area() -> None:
    clip = Calibration(DEV, INTUOS, area=AreaSettings(Area(0.5, 0.5, 0.5, 0.5)))
    out = clip.apply(sample(0.95, 0.5))
    assert out.x == pytest.approx(1.0) and out.y == pytest.approx(0.5)
    drop = Calibration(DEV, INTUOS, area=AreaSettings(Area(0.5, 0.5, 0.5, 0.5), outside="drop"))
    with pytest.raises(OutsideArea):
        drop.apply(sample(0.95, 0.5))
    assert drop.apply_or_none(sample(0.95, 0.5)) is None
    assert drop.apply(sample(0.5, 0.5)).x == pytest.approx(0.5)


def test_apply_as_the_normaliser_transform_hook() -> None:
    normalise = pytest.importorskip("station.drivers.normalise")
    from station.drivers.raw import Axis, AxisRanges, RawSample

    ranges = AxisRanges(Axis(0, 44704, 200), Axis(0, 27940, 200), pressure=Axis(0, 2047))
    cal = Calibration(DEV, INTUOS, area=AreaSettings(Area(0.5, 0.5, 0.5, 0.5), outside="drop"))
    raw_seen: list[PenSample] = []
    n = normalise.Normaliser(ranges, transform=cal.apply, on_device_sample=raw_seen.append)
    out = []
    for k, x in enumerate((22352, 33528, 43000)):  # centre, 3/4 across, outside the area
        out += n.feed(RawSample(time=0.01 * k, proximity=True, x=x, y=13970, pressure=1000,
                                tip=True))
    xs = [s.x for s in out]
    assert xs[0] == pytest.approx(0.5, abs=1e-4) and xs[1] == pytest.approx(1.0, abs=1e-4)
    assert len(out) == 2 and n.stats.rejected == 1  # the outside sample was dropped
    assert [s.x for s in raw_seen][:2] == pytest.approx([0.5, 0.75], abs=1e-4)  # raw kept
