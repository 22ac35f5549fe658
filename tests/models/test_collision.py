"""Tests for rpod.models.collision (paper 000 Sec. II-B) against independent computations.

References: closed forms (aligned boxes, the paper's capture pose), the gauge of the Minkowski
difference (scipy ConvexHull, no LP), bisection on ``shapes.separation_distance`` (an SOCP on
vertices, no scaling), and central finite differences of ``evaluate``.
"""

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RotationMatrix
from pydrake.solvers import ClarabelSolver
from scipy.spatial import ConvexHull

from rpod.models import collision
from rpod.models.collision import ScalingMetric, ScalingMetricProgram, scaling_metric
from rpod.models.shapes import (
    ConvexPolytope,
    separation_distance,
    soft_capture_chaser_hull,
    soft_capture_target_hull,
)

TARGET = soft_capture_target_hull()
CHASER = soft_capture_chaser_hull()
# Clarabel runs at 1e-12 tolerances; alpha (O(1)) then agrees with an exact simplex solution to
# ~3e-10 relative, so 1e-8 is a safe bound that still catches any geometric or sign mistake.
ALPHA_TOL = 1e-8
ELEMENTARY_ROTATIONS = (
    RotationMatrix.MakeXRotation,
    RotationMatrix.MakeYRotation,
    RotationMatrix.MakeZRotation,
)


def _random_rotation(rng) -> np.ndarray:
    q = rng.normal(size=4)
    return RotationMatrix(Quaternion(q / np.linalg.norm(q))).matrix()


def _random_pose_pair(rng, distance_range):
    """Random attitudes, a at a random place, b at a random direction and distance from a."""
    p_a = rng.normal(size=3) * 20.0
    direction = rng.normal(size=3)
    p_b = p_a + rng.uniform(*distance_range) * direction / np.linalg.norm(direction)
    return _random_rotation(rng), p_a, _random_rotation(rng), p_b


def _minkowski_gauge(polytope_a, R_a, p_a, polytope_b, R_b, p_b):
    """alpha and d alpha / d p_b from the hull of the Minkowski difference, with no LP.

    Both scaled bodies share a point iff p_b - p_a lies in alpha (R_a P_a - R_b P_b), so alpha is
    the gauge of d = p_b - p_a in that set: max over its facets n . z <= c of (n . d) / c,
    whose gradient in d (i.e. in p_b) is n / c of the active facet.
    """
    differences = (R_a @ polytope_a.vertices.T).T[:, None, :] - (R_b @ polytope_b.vertices.T).T
    hull = ConvexHull(differences.reshape(-1, 3))
    normals, offsets = hull.equations[:, :3], -hull.equations[:, 3]
    ratios = normals @ (np.asarray(p_b) - np.asarray(p_a)) / offsets
    k = int(np.argmax(ratios))
    return ratios[k], normals[k] / offsets[k]


def _scaled(polytope: ConvexPolytope, s: float) -> ConvexPolytope:
    return ConvexPolytope(A=polytope.A, b=s * polytope.b, vertices=s * polytope.vertices)


# ---- Closed forms ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "d_local",
    [[3.0, 0.2, -0.1], [0.1, -2.5, 0.3], [0.2, 0.3, 1.9], [0.4, 0.1, 0.05], [-1.5, 1.0, 0.2]],
)
def test_aligned_boxes_match_closed_form(d_local):
    # Two boxes with the same attitude R: the Minkowski difference is a box of half-sizes
    # h_a + h_b, so alpha = max_i |d_i| / (h_a,i + h_b,i) with d in the common body frame, and
    # d alpha / d p_b = sign(d_k) R e_k / (h_a,k + h_b,k) for the maximising axis k.
    rng = np.random.default_rng(5)
    half_a, half_b = np.array([0.5, 1.0, 1.5]), np.array([0.3, 0.2, 0.75])
    a = ConvexPolytope.box(2.0 * half_a)
    b = ConvexPolytope.box(2.0 * half_b)
    R = _random_rotation(rng)
    p_a = np.array([100.0, -40.0, 7.0])
    d_local = np.asarray(d_local)
    ratios = np.abs(d_local) / (half_a + half_b)
    k = int(np.argmax(ratios))
    metric = scaling_metric(a, R, p_a, b, R, p_a + R @ d_local)
    assert metric.status == "ok"
    assert metric.alpha == pytest.approx(ratios[k], abs=ALPHA_TOL)
    expected_gradient = np.sign(d_local[k]) * R[:, k] / (half_a[k] + half_b[k])
    np.testing.assert_allclose(metric.d_alpha_d_p_b, expected_gradient, atol=1e-8)
    np.testing.assert_allclose(metric.d_alpha_d_p_a, -expected_gradient, atol=1e-8)
    # The closed form covers separated (alpha > 1) and penetrating (alpha < 1) cases alike.
    assert (metric.alpha > 1.0) == (separation_distance(a, R, p_a, b, R, p_a + R @ d_local) > 0)


def test_coincident_origins_give_zero():
    metric = scaling_metric(TARGET, np.eye(3), np.ones(3), CHASER, np.eye(3), np.ones(3))
    assert metric.status == "ok"
    assert metric.alpha == pytest.approx(0.0, abs=ALPHA_TOL)


def test_paper_capture_pose_closed_form():
    # Paper 000 (13): at capture the chaser's centre is at R_LT (D_c + D_t) = R_LT [0, 0, 5.4] m
    # and its attitude is R_LT Ry(180 deg), so its +z face (z = 1.2099 m) faces the target's
    # +z face (z = 1.2 m). The hulls are stacked along z_T and their scaled caps meet first:
    # alpha = 5.4 / (1.2 + 1.2099), whatever R_LT.
    rng = np.random.default_rng(13)
    R_LT = _random_rotation(rng)
    R_LC = R_LT @ RotationMatrix.MakeYRotation(np.pi).matrix()
    metric = scaling_metric(TARGET, R_LT, np.zeros(3), CHASER, R_LC, R_LT @ [0.0, 0.0, 5.4])
    assert metric.status == "ok"
    assert metric.alpha == pytest.approx(5.4 / (1.2 + 1.2099), abs=ALPHA_TOL)


# ---- Independent computations on random poses of the paper's hulls -----------------------------


def test_matches_minkowski_gauge_on_random_poses():
    rng = np.random.default_rng(1)
    program = ScalingMetricProgram(CHASER, TARGET)
    for _ in range(100):
        pose = _random_pose_pair(rng, (0.1, 40.0))
        metric = program.evaluate(*pose)
        alpha, gradient_p_b = _minkowski_gauge(CHASER, pose[0], pose[1], TARGET, pose[2], pose[3])
        assert metric.status == "ok"
        assert metric.alpha == pytest.approx(alpha, rel=ALPHA_TOL, abs=ALPHA_TOL)
        np.testing.assert_allclose(metric.d_alpha_d_p_b, gradient_p_b, atol=1e-8)


def test_many_poses_in_one_lp_match_the_minkowski_gauge_and_one_by_one():
    """evaluate_many: the K LPs side by side are the K LPs (values, gradients, statuses); a
    pose that is not finite is reported as evaluate reports it, and the rest still solve."""
    rng = np.random.default_rng(4)
    program = ScalingMetricProgram(CHASER, TARGET)
    poses = [_random_pose_pair(rng, (0.1, 60.0)) for _ in range(40)]
    R_a, p_a, R_b, p_b = (np.array([pose[i] for pose in poses]) for i in range(4))
    many = program.evaluate_many(R_a, p_a, R_b, p_b)
    for pose, metric in zip(poses, many):
        one = program.evaluate(*pose)
        alpha, gradient_p_b = _minkowski_gauge(CHASER, pose[0], pose[1], TARGET, pose[2], pose[3])
        assert metric.status == "ok"
        assert metric.alpha == pytest.approx(alpha, rel=ALPHA_TOL, abs=ALPHA_TOL)
        np.testing.assert_allclose(metric.d_alpha_d_p_b, gradient_p_b, atol=1e-8)
        for name in ("d_alpha_d_p_a", "d_alpha_d_theta_a", "d_alpha_d_theta_b"):
            np.testing.assert_allclose(getattr(metric, name), getattr(one, name), atol=1e-7)
    p_a[3] = np.nan
    with_nan = program.evaluate_many(R_a, p_a, R_b, p_b)
    assert with_nan[3].status == "non_finite_pose"
    assert [m.alpha for i, m in enumerate(with_nan) if i != 3] == pytest.approx(
        [m.alpha for i, m in enumerate(many) if i != 3], rel=ALPHA_TOL
    )
    with pytest.raises(ValueError, match="rotation"):
        program.evaluate_many(2.0 * R_a, p_a, R_b, p_b)


def test_many_poses_recheck_every_block_and_solve_a_failed_one_alone(monkeypatch):
    rng = np.random.default_rng(5)
    program = ScalingMetricProgram(CHASER, TARGET)
    poses = [_random_pose_pair(rng, (0.5, 30.0)) for _ in range(6)]
    R_a, p_a, R_b, p_b = (np.array([pose[i] for pose in poses]) for i in range(4))
    checked = []
    real_check = program._kkt_holds_many

    def check_then_fail_block_2(M, x, lam, h_b):
        good = real_check(M, x, lam, h_b)
        checked.append(good.copy())
        assert not real_check(M, x, 1.5 * lam, h_b).any()  # a wrong multiplier fails it
        good[2] = False
        return good

    monkeypatch.setattr(program, "_kkt_holds_many", check_then_fail_block_2)
    alone = []
    real_evaluate = program.evaluate
    monkeypatch.setattr(program, "evaluate", lambda *pose: alone.append(1) or real_evaluate(*pose))
    many = program.evaluate_many(R_a, p_a, R_b, p_b)
    assert checked[0].all() and len(alone) == 1  # only the failed block was solved alone
    for pose, metric in zip(poses, many):
        assert metric.alpha == pytest.approx(real_evaluate(*pose).alpha, rel=ALPHA_TOL)


def test_matches_bisection_on_separation_distance():
    # alpha* is the scaling at which the Euclidean distance of the scaled bodies reaches 0.
    # separation_distance reports 0 below 1e-9 m and the distance grows at >~1 m per unit of
    # scaling for these metre-sized hulls, so the bisection's zero is within ~1e-9 of alpha*;
    # 60 halvings of [0, 20] leave ~2e-17. Tolerance 1e-7: 100x that bias.
    rng = np.random.default_rng(2)
    for distance_range in [(2.0, 4.0), (5.0, 12.0), (12.0, 30.0)]:
        R_a, p_a, R_b, p_b = _random_pose_pair(rng, distance_range)
        metric = scaling_metric(TARGET, R_a, p_a, CHASER, R_b, p_b)
        low, high = 0.0, 20.0
        for _ in range(60):
            s = 0.5 * (low + high)
            d = separation_distance(_scaled(TARGET, s), R_a, p_a, _scaled(CHASER, s), R_b, p_b)
            low, high = (s, high) if d > 0.0 else (low, s)
        assert metric.alpha == pytest.approx(0.5 * (low + high), abs=1e-7)


def test_alpha_above_one_iff_separated():
    rng = np.random.default_rng(3)
    program = ScalingMetricProgram(TARGET, CHASER)
    counts = {True: 0, False: 0}
    for _ in range(150):
        pose = _random_pose_pair(rng, (2.0, 9.0))
        metric = program.evaluate(*pose)
        assert metric.status == "ok"
        if abs(metric.alpha - 1.0) < 1e-6:  # grazing contact: both tests are at round-off
            continue
        separated = separation_distance(TARGET, pose[0], pose[1], CHASER, pose[2], pose[3]) > 0.0
        assert (metric.alpha > 1.0) == separated
        counts[separated] += 1
    assert counts[True] >= 30 and counts[False] >= 30  # both branches exercised


def test_gradients_match_central_differences():
    # h = 1e-5 in metres and radians. Truncation ~h^2 |alpha'''| ~ 3e-10 (2.7e-8 observed at
    # h = 1e-4); round-off ~1e-14 / h = 1e-9. Observed worst error 6e-10 on gradients of
    # size ~0.1-1, so 1e-7 keeps a 100x margin and still catches any sign or frame error.
    rng = np.random.default_rng(4)
    program = ScalingMetricProgram(TARGET, CHASER)
    h = 1e-5
    for _ in range(8):
        # Separated: the hulls' circumradii (~4.66 m and ~3.80 m) sum to < 9 m.
        R_a, p_a, R_b, p_b = _random_pose_pair(rng, (9.0, 20.0))
        metric = program.evaluate(R_a, p_a, R_b, p_b)
        assert metric.status == "ok" and metric.alpha > 1.0

        def alpha(R_a=R_a, p_a=p_a, R_b=R_b, p_b=p_b):
            return program.evaluate(R_a, p_a, R_b, p_b).alpha

        numeric = np.zeros((4, 3))
        for k in range(3):
            step = h * np.eye(3)[k]
            turn_plus = ELEMENTARY_ROTATIONS[k](h).matrix()  # exp([h e_k]x), on the left
            turn_minus = ELEMENTARY_ROTATIONS[k](-h).matrix()
            numeric[0, k] = alpha(p_a=p_a + step) - alpha(p_a=p_a - step)
            numeric[1, k] = alpha(R_a=turn_plus @ R_a) - alpha(R_a=turn_minus @ R_a)
            numeric[2, k] = alpha(p_b=p_b + step) - alpha(p_b=p_b - step)
            numeric[3, k] = alpha(R_b=turn_plus @ R_b) - alpha(R_b=turn_minus @ R_b)
        numeric /= 2.0 * h
        analytic = np.array(
            [
                metric.d_alpha_d_p_a,
                metric.d_alpha_d_theta_a,
                metric.d_alpha_d_p_b,
                metric.d_alpha_d_theta_b,
            ]
        )
        np.testing.assert_allclose(analytic, numeric, atol=1e-7)
        # Rigid-motion invariance, exact from the LP's stationarity: a common translation, and a
        # common rotation theta about p_a (which also moves p_b by theta x d), leave alpha fixed.
        np.testing.assert_allclose(metric.d_alpha_d_p_a + metric.d_alpha_d_p_b, 0.0, atol=1e-10)
        total_turn = (
            metric.d_alpha_d_theta_a
            + metric.d_alpha_d_theta_b
            + np.cross(p_b - p_a, metric.d_alpha_d_p_b)
        )
        np.testing.assert_allclose(total_turn, 0.0, atol=1e-8)


def test_swapping_the_bodies_swaps_the_gradients():
    rng = np.random.default_rng(6)
    for _ in range(10):
        R_a, p_a, R_b, p_b = _random_pose_pair(rng, (1.0, 15.0))
        ab = scaling_metric(TARGET, R_a, p_a, CHASER, R_b, p_b)
        ba = scaling_metric(CHASER, R_b, p_b, TARGET, R_a, p_a)
        assert ab.alpha == pytest.approx(ba.alpha, rel=ALPHA_TOL)
        for x, y in [
            (ab.d_alpha_d_p_a, ba.d_alpha_d_p_b),
            (ab.d_alpha_d_theta_a, ba.d_alpha_d_theta_b),
            (ab.d_alpha_d_p_b, ba.d_alpha_d_p_a),
            (ab.d_alpha_d_theta_b, ba.d_alpha_d_theta_a),
        ]:
            np.testing.assert_allclose(x, y, atol=1e-8)


def test_accepts_rotation_matrix_objects_and_reuses_the_program():
    R_a, R_b = RotationMatrix.MakeZRotation(0.3), RotationMatrix.MakeXRotation(-1.1)
    p_b = np.array([4.0, 5.0, -1.0])
    first = scaling_metric(TARGET, R_a, np.zeros(3), CHASER, R_b, p_b)
    # Equal data in new objects hit the same cached program; matrices give the same answer.
    target_copy = soft_capture_target_hull()
    cached = len(collision._PROGRAMS)
    second = scaling_metric(target_copy, R_a.matrix(), np.zeros(3), CHASER, R_b.matrix(), p_b)
    assert len(collision._PROGRAMS) == cached
    assert second.alpha == first.alpha and second.status == first.status == "ok"


# ---- Failures: statuses, not exceptions; bad inputs: exceptions ---------------------------------


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_pose_returns_status(bad):
    program = ScalingMetricProgram(TARGET, CHASER)
    R_bad = np.eye(3)
    R_bad[1, 2] = bad
    for args in [
        (np.eye(3), [bad, 0.0, 0.0], np.eye(3), [5.0, 0.0, 0.0]),
        (np.eye(3), np.zeros(3), R_bad, [5.0, 0.0, 0.0]),
    ]:
        metric = program.evaluate(*args)
        assert metric.status == "non_finite_pose"
        assert np.isnan(metric.alpha) and np.all(np.isnan(metric.d_alpha_d_theta_b))
    # The program is still usable afterwards.
    assert program.evaluate(np.eye(3), np.zeros(3), np.eye(3), [8.0, 0.0, 0.0]).status == "ok"


def test_solver_failure_returns_its_word():
    # One interior-point iteration cannot reach 1e-12: the solver stops and says so.
    program = ScalingMetricProgram(TARGET, CHASER)
    program._options.SetOption(ClarabelSolver.id(), "max_iter", 1)
    metric = program.evaluate(np.eye(3), np.zeros(3), np.eye(3), [6.0, 1.0, 0.0])
    assert isinstance(metric, ScalingMetric)
    assert metric.status == "kIterationLimit"  # Drake's SolutionResult name
    assert np.isnan(metric.alpha) and np.all(np.isnan(metric.d_alpha_d_p_a))


def test_rejects_bad_inputs():
    # The unit cube moved to x in [0, 1]: its origin lies on a face (b has a zero).
    cube = ConvexPolytope.box([1.0, 1.0, 1.0])
    shifted = ConvexPolytope(
        A=cube.A, b=cube.b + [0.5, 0.0, 0.0, -0.5, 0.0, 0.0], vertices=cube.vertices + [0.5, 0, 0]
    )
    with pytest.raises(ValueError, match="b > 0"):
        ScalingMetricProgram(shifted, CHASER)
    program = ScalingMetricProgram(TARGET, CHASER)
    with pytest.raises(ValueError, match="orthonormal"):
        program.evaluate(2.0 * np.eye(3), np.zeros(3), np.eye(3), [5.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="3 entries"):
        program.evaluate(np.eye(3), np.zeros(2), np.eye(3), [5.0, 0.0, 0.0])
