"""Fitting with known ground truth: affine, projective, rotated, mirrored, noise, misclicks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from station.calibration.errors import DegeneratePoints
from station.calibration.fit import (
    PointSet,
    fit_affine,
    fit_homography,
    fit_points,
    leave_one_out,
    outlier_limit,
)
from station.calibration.geometry import CHI2_2_0999, hartley, homogeneous, project, rotation

RES = 200.0  # device units per mm
DEVICE_MAX = (95840.0, 54260.0)


def grid(n: int = 9) -> np.ndarray:
    k = int(round(math.sqrt(n)))
    g = np.linspace(0.1, 0.9, k)
    return np.array([(x, y) for y in g for x in g])


def to_device(truth: np.ndarray, canvas: np.ndarray) -> np.ndarray:
    """Where a perfect tap for each target lands on the device (truth: device → canvas)."""
    return project(np.linalg.inv(truth), canvas)


def affine_truth(rot_deg: float = 0.0, mirror: bool = False) -> np.ndarray:
    """Device units → canvas: scale to [0,1], optional mirror/rotation about the centre."""
    s = np.diag([1 / DEVICE_MAX[0], 1 / DEVICE_MAX[1], 1.0])
    centre = np.array([[1, 0, 0.5], [0, 1, 0.5], [0, 0, 1.0]])
    back = np.array([[1, 0, -0.5], [0, 1, -0.5], [0, 0, 1.0]])
    flip = np.diag([-1.0, 1.0, 1.0]) if mirror else np.eye(3)
    shear = np.array([[1.0, 0.03, 0.01], [-0.02, 0.98, -0.015], [0, 0, 1.0]])
    return centre @ rotation(rot_deg) @ flip @ shear @ back @ s


def projective_truth() -> np.ndarray:
    h = affine_truth(3.0)
    p = np.array([[1, 0, 0], [0, 1, 0], [0.04, -0.03, 1.0]])
    shift = np.array([[1, 0, -0.5], [0, 1, -0.5], [0, 0, 1.0]])
    m = np.linalg.inv(shift) @ p @ shift @ h
    return m / m[2, 2]


def noisy(dev: np.ndarray, sigma_canvas: float, rng: np.random.Generator) -> np.ndarray:
    # noise of sigma canvas units ≈ sigma * device size device units
    return dev + rng.normal(0.0, sigma_canvas, dev.shape) * np.array(DEVICE_MAX)


def max_map_error(fitted: np.ndarray, truth: np.ndarray) -> float:
    pts = to_device(truth, np.random.default_rng(5).uniform(0.1, 0.9, (300, 2)))
    return float(np.abs(project(fitted, pts) - project(truth, pts)).max())


def test_hartley_normalisation_centres_and_scales() -> None:
    pts = np.random.default_rng(0).uniform(1000, 90000, (20, 2))
    t = hartley(pts)
    n = (homogeneous(pts) @ t.T)[:, :2]
    assert np.allclose(n.mean(axis=0), 0, atol=1e-12)
    assert math.isclose(float(np.sqrt((n**2).sum(axis=1).mean())), math.sqrt(2), rel_tol=1e-12)


@pytest.mark.parametrize("rot, mirror", [(0.0, False), (90.0, False), (180.0, False),
                                         (-7.5, False), (0.0, True), (30.0, True)])
def test_exact_affine_recovered_to_rounding(rot: float, mirror: bool) -> None:
    truth = affine_truth(rot, mirror)
    can = grid(9)
    mapping = fit_affine(PointSet(to_device(truth, can), can))
    assert np.allclose(mapping.matrix, truth / truth[2, 2], rtol=0, atol=1e-12)
    assert mapping.matrix[2].tolist() == [0.0, 0.0, 1.0]


def test_exact_homography_recovered_from_four_points() -> None:
    truth = projective_truth()
    can = np.array([(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9)])
    mapping = fit_homography(PointSet(to_device(truth, can), can))
    assert max_map_error(mapping.matrix, truth) < 1e-10


@pytest.mark.parametrize("model, truth_fn", [("affine", lambda: affine_truth(12.0, True)),
                                             ("homography", projective_truth)])
def test_noise_and_misclicks_recovered_within_noise(model: str, truth_fn: object) -> None:
    truth = truth_fn()  # type: ignore[operator]
    sigma = 0.001
    rng = np.random.default_rng(42)
    can = grid(16)
    dev = noisy(to_device(truth, can), sigma, rng)
    bad = [3, 10]
    dev[3] += np.array([0.06, -0.04]) * np.array(DEVICE_MAX)  # two misclicks
    dev[10] += np.array([-0.05, -0.05]) * np.array(DEVICE_MAX)
    rep = fit_points(PointSet(dev, can), model)
    assert rep.outliers == bad
    assert len(rep.inliers) == 14
    # the mapping is as good as the noise allows: within 3 sigma everywhere
    assert max_map_error(rep.mapping.matrix, truth) < 3 * sigma
    assert 0.5 * sigma < rep.sigma < 2 * sigma  # noise estimated from the inliers
    assert rep.rms < 2 * sigma
    # leave-one-out error is larger than the in-sample RMS (honest), same order
    assert rep.loo_rms is not None and rep.rms < rep.loo_rms < 4 * sigma


def test_plain_least_squares_is_ruined_by_the_misclick() -> None:
    truth = affine_truth(5.0)
    rng = np.random.default_rng(1)
    can = grid(9)
    dev = noisy(to_device(truth, can), 0.0005, rng)
    dev[4] += np.array([0.08, 0.0]) * np.array(DEVICE_MAX)
    plain = fit_points(PointSet(dev, can), "affine", robust=False)
    robust = fit_points(PointSet(dev, can), "affine")
    assert plain.outliers == [] and robust.outliers == [4]
    assert max_map_error(plain.mapping.matrix, truth) > 0.005
    assert max_map_error(robust.mapping.matrix, truth) < 0.0015


def test_no_false_misclicks_on_clean_noisy_data() -> None:
    truth = projective_truth()
    flagged = 0
    for seed in range(20):
        rng = np.random.default_rng(seed)
        can = grid(9)
        dev = noisy(to_device(truth, can), 0.001, rng)
        flagged += len(fit_points(PointSet(dev, can), "homography").outliers)
    # 180 good points at a 0.1 % per-point test level: a false alarm or two at most
    assert flagged <= 2


def test_auto_picks_homography_for_projective_and_affine_for_affine() -> None:
    rng = np.random.default_rng(3)
    can = grid(9)
    proj = fit_points(PointSet(noisy(to_device(projective_truth(), can), 0.0003, rng), can),
                      "auto")
    aff = fit_points(PointSet(noisy(to_device(affine_truth(4.0), can), 0.0003, rng), can), "auto")
    assert proj.model == "homography"
    assert aff.model == "affine"
    assert set(proj.candidates) == {"affine", "homography"}
    assert proj.candidates["homography"]["loo_rms"] < proj.candidates["affine"]["loo_rms"]
    assert proj.candidates["homography"]["aicc"] < proj.candidates["affine"]["aicc"]


def test_leave_one_out_exact_data_is_zero_and_needs_redundancy() -> None:
    truth = affine_truth(1.0)
    can = grid(9)
    loo = leave_one_out(PointSet(to_device(truth, can), can), "affine")
    assert all(v is not None and v < 1e-12 for v in loo)
    four = can[[0, 2, 6, 8]]
    pts = PointSet(to_device(truth, four), four)
    assert leave_one_out(pts, "homography") == [None] * 4  # 3 left cannot fit 8 parameters


def test_residuals_in_millimetres() -> None:
    truth = affine_truth(0.0)
    can = grid(9)
    dev = to_device(truth, can)
    dev[0, 0] += 2.0 * RES  # 2 mm off in x on the tablet
    rep = fit_points(PointSet(dev, can), "affine", robust=False, units_per_mm=(RES, RES))
    assert rep.residuals_mm is not None
    # least squares spreads the 2 mm: the point keeps most of it, in mm, in x
    assert 1.0 < abs(rep.residuals_mm[0, 0]) < 2.0
    js = rep.to_json()
    assert js["max_mm"] == pytest.approx(float(np.max(np.linalg.norm(rep.residuals_mm, axis=1))))


def test_outlier_limit_is_f_quantile_and_tends_to_chi2() -> None:
    assert outlier_limit(None) == pytest.approx(CHI2_2_0999)
    assert outlier_limit(10**7) == pytest.approx(CHI2_2_0999, rel=1e-5)
    # F(2, 6) 0.999 quantile is 27.0 (tables): the limit on d² is twice that
    assert outlier_limit(6) == pytest.approx(2 * 27.0, rel=1e-3)


# -- degenerate inputs -----------------------------------------------------------


def test_collinear_points_refused() -> None:
    can = np.array([(0.1, 0.1), (0.5, 0.5), (0.9, 0.9), (0.3, 0.3)])
    with pytest.raises(DegeneratePoints, match="collinear"):
        fit_points(PointSet(can * 1000, can), "affine")


def test_nearly_collinear_points_refused() -> None:
    can = np.array([(0.1, 0.1), (0.5, 0.5 + 1e-6), (0.9, 0.9), (0.3, 0.3)])
    with pytest.raises(DegeneratePoints, match="collinear"):
        fit_points(PointSet(can * 1000, can), "affine")


def test_duplicates_refused_with_rows() -> None:
    can = grid(9)
    dev = to_device(affine_truth(), can)
    dev[5] = dev[2]
    with pytest.raises(DegeneratePoints, match="duplicate point: row 2 and row 5"):
        fit_points(PointSet(dev, can), "affine")


@pytest.mark.parametrize("model, n", [("affine", 2), ("homography", 3)])
def test_too_few_points_refused(model: str, n: int) -> None:
    can = grid(9)[[0, 2, 8][:n]]
    with pytest.raises(DegeneratePoints, match="needs at least"):
        fit_points(PointSet(to_device(affine_truth(), can), can), model)


def test_nan_refused() -> None:
    can = grid(9)
    dev = to_device(affine_truth(), can)
    dev[4, 1] = np.nan
    with pytest.raises(DegeneratePoints, match="NaN or infinite at row 4"):
        fit_points(PointSet(dev, can), "affine")


def test_three_collinear_of_four_refused_for_homography() -> None:
    can = np.array([(0.1, 0.1), (0.5, 0.1), (0.9, 0.1), (0.5, 0.9)])
    with pytest.raises(DegeneratePoints, match="no three on a line"):
        fit_points(PointSet(to_device(affine_truth(), can), can), "homography")


# -- parallax --------------------------------------------------------------------


def parallax_points(h: tuple[float, float], sigma: float, seed: int) -> tuple[PointSet, np.ndarray]:
    truth = affine_truth(2.0)
    rng = np.random.default_rng(seed)
    five = np.array([(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9), (0.5, 0.5)])
    can = np.vstack([grid(9), five, five, five, five])
    tilt = np.vstack([np.zeros((9, 2)), np.tile([[-30.0, 30.0]], (5, 1)),
                      np.tile([[30.0, -30.0]], (5, 1)), np.tile([[30.0, 30.0]], (5, 1)),
                      np.tile([[-30.0, -30.0]], (5, 1))])
    tilt += rng.normal(0.0, 2.0, tilt.shape)
    dev = to_device(truth, can) - np.array(h) * np.tan(np.radians(tilt))
    dev = noisy(dev, sigma, rng)
    return PointSet(dev, can, tilt), truth


def test_parallax_recovered_and_removes_the_error_a_plain_fit_cannot() -> None:
    h = (3.0 * RES, -2.0 * RES)  # 3 mm and -2 mm per unit tan(tilt)
    sigma = 0.0005
    pts, _truth = parallax_points(h, sigma, 7)
    plain = fit_points(pts, "affine", parallax=False, robust=False)
    joint = fit_points(pts, "affine", parallax=True, units_per_mm=(RES, RES))
    assert joint.outliers == []
    assert joint.parallax_mm is not None
    assert joint.parallax_mm[0] == pytest.approx(3.0, abs=0.25)
    assert joint.parallax_mm[1] == pytest.approx(-2.0, abs=0.25)
    assert joint.rms < 2 * sigma  # parallax explained: residuals down to the noise
    assert plain.rms > 5 * joint.rms  # the plain fit cannot absorb a tilt-dependent shift
    # applying the fitted parallax per sample puts tilted taps on their targets
    tilted = pts.tilt is not None and np.abs(pts.tilt).max(axis=1) > 10
    mapped = joint.mapping.map(pts.device[tilted], pts.tilt[tilted])
    err = np.hypot(*(mapped - pts.canvas[tilted]).T)
    assert err.max() < 4 * sigma
    plain_err = np.hypot(*(plain.mapping.map(pts.device[tilted]) - pts.canvas[tilted]).T)
    assert plain_err.mean() > 3 * err.mean()


def test_parallax_homography_model_too() -> None:
    pts, _truth = parallax_points((2.0 * RES, 2.0 * RES), 0.0003, 11)
    rep = fit_points(pts, "homography", parallax=True, units_per_mm=(RES, RES))
    assert rep.parallax_mm is not None
    assert rep.parallax_mm[0] == pytest.approx(2.0, abs=0.25)
    assert rep.parallax_mm[1] == pytest.approx(2.0, abs=0.25)


def test_the_robust_search_ranks_subsets_without_refining_each_to_the_last_digit(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A 29-tap parallax homography with one misclick: the robust search tries ~400
    minimal subsets; refined to 1e-14 each took ~240 evaluations (35 s of CPU at a
    22-tap calibration's end, the installer waiting).  Its winner is refitted in full."""
    from station.calibration import solve

    pts, _truth = parallax_points((2.0 * RES, 2.0 * RES), 0.0003, 11)
    dev = pts.device.copy()
    dev[3] += np.array([0.03, -0.02]) * np.array(DEVICE_MAX)
    pts = PointSet(dev, pts.canvas, pts.tilt)
    calls = 0
    real = solve.residuals_jac

    def counted(*args: object, **kw: object) -> object:
        nonlocal calls
        calls += 1
        return real(*args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(solve, "residuals_jac", counted)
    rep = fit_points(pts, "homography", parallax=True, units_per_mm=(RES, RES))
    assert rep.outliers == [3]
    assert rep.parallax_mm is not None
    assert rep.parallax_mm == pytest.approx((2.0, 2.0), abs=0.25)
    assert calls < 15 * 2 * 400, calls  # main: 62 496 (this 29-tap set)


def test_parallax_without_tilt_variation_refused() -> None:
    can = grid(9)
    pts = PointSet(to_device(affine_truth(), can), can, np.full((9, 2), 10.0))
    with pytest.raises(DegeneratePoints, match="hardly varies"):
        fit_points(pts, "affine", parallax=True)
    with pytest.raises(DegeneratePoints, match="tilt_x,tilt_y columns"):
        fit_points(PointSet(pts.device, pts.canvas), "affine", parallax=True)


def test_five_point_misclick_at_a_corner_is_reported_as_ambiguous() -> None:
    # corners + centre under an affine map: a slip at one corner breaks the same two
    # constraints (parallelogram, centre = mean) as the opposite slip at the opposite corner
    can = np.array([(0.1, 0.1), (0.9, 0.1), (0.9, 0.9), (0.1, 0.9), (0.5, 0.5)])
    truth = affine_truth(3.0)
    rng = np.random.default_rng(4)
    dev = noisy(to_device(truth, can), 0.0005, rng)
    dev[0] += np.array([0.04, -0.03]) * np.array(DEVICE_MAX)
    rep = fit_points(PointSet(dev, can), "affine", noise=0.0005)
    assert rep.outliers in ([0], [2])
    other = 2 if rep.outliers == [0] else 0
    assert rep.ambiguous == {rep.outliers[0]: [other]}
    assert any("cannot be told from" in n for n in rep.notes)
    assert "ambiguous_outliers" in rep.to_json()
    # a misclick at the centre is located without doubt
    dev = noisy(to_device(truth, can), 0.0005, rng)
    dev[4] += np.array([0.04, -0.03]) * np.array(DEVICE_MAX)
    rep = fit_points(PointSet(dev, can), "affine", noise=0.0005)
    assert rep.outliers == [4] and rep.ambiguous == {}


def test_known_noise_finds_ten_sigma_misclicks_in_nine_points() -> None:
    truth = projective_truth()
    found = 0
    for seed in range(20):
        rng = np.random.default_rng(100 + seed)
        can = grid(9)
        dev = noisy(to_device(truth, can), 0.001, rng)
        k = seed % 9
        ang = rng.uniform(0, 2 * np.pi)
        dev[k] += 0.010 * np.array([np.cos(ang), np.sin(ang)]) * np.array(DEVICE_MAX)
        rep = fit_points(PointSet(dev, can), "homography", noise=0.001)
        found += rep.outliers == [k]
    assert found >= 17  # 10 sigma misclicks: found (alone) in at least 85 % of the cases
