"""Tests for rpod.planners.reachability: paper 004's certified safe-start sets (eqs. 13-16), the
double integrator of Sec. 8.4 (eq. 17) and the backward viability kernel (Sec. 10.2)."""

import math

import numpy as np
import pytest
from scipy.optimize import linprog

from rpod.models.cw import cw_state_transition, cw_zoh_input
from rpod.models.los_corridor import LosCorridor, sync_range_m
from rpod.planners import reachability as reach
from rpod.planners.los_prediction import BodyFrameStep

DEG = math.pi / 180.0
TAN = math.tan(30.0 * DEG)
C45 = math.sqrt(0.5)
N = reach.MEAN_MOTION_RAD_S
CORRIDOR = LosCorridor()


@pytest.fixture(scope="module")
def grid_terms():
    grid = reach.SafeStartGrid.over_cone(CORRIDOR)
    return grid, reach.GridSlack.on(grid, CORRIDOR)


def _points_grid(points) -> reach.SafeStartGrid:
    """A 'grid' of hand-picked points (all of them in the corridor)."""
    points = np.asarray(points, dtype=float)
    assert np.all(CORRIDOR.contains(points))
    return reach.SafeStartGrid(points[:, 0], points[:, 1], points, np.ones(len(points), bool), 0.0)


# --- eq. 13, eq. 14 and criterion (16) at hand-worked points ---------------------------------


def test_erosion_on_the_axis_by_hand():
    # p = (0, 100, 0), 1 deg/s, 0.2 m/s^2: v_rot = [100 w, 0, 0], a_i^T v_rot = 100 w cos(theta_i)
    w, a = 1.0 * DEG, 0.2
    delta = reach.nominal_erosion(np.array([[0.0, 100.0, 0.0]]), CORRIDOR, w, a)[0]
    d1 = (100.0 * w) ** 2 / (2.0 * a)  # 7.615 m: face 1 (theta = 0) is approached head on
    expected = [d1, 0.5 * d1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5 * d1, 0.0]  # cos^2(45 deg) = 1/2
    np.testing.assert_allclose(delta, expected, rtol=1e-12, atol=1e-12)
    assert d1 == pytest.approx(7.6154, abs=1e-4)


def test_erosion_off_the_axis_by_hand():
    # p = (50, 100, 0), 2 deg/s, 0.05 m/s^2: v_rot = w [100, -50, 0].
    w, a = 2.0 * DEG, 0.05
    delta = reach.nominal_erosion(np.array([[50.0, 100.0, 0.0]]), CORRIDOR, w, a)[0]
    k = w**2 / (2.0 * a)
    face1 = k * (100.0 + 50.0 * TAN) ** 2  # a_1 = [1, -t, 0]
    face2 = k * (100.0 * C45 + 50.0 * TAN) ** 2  # a_2 = [c, -t, c]
    face3 = k * (50.0 * TAN) ** 2  # a_3 = [0, -t, 1]: x > 0 moves toward it
    floor = k * 50.0**2  # a_9 = [0, -1, 0]: the floor rate is -w x
    expected = [face1, face2, face3, 0.0, 0.0, 0.0, face3, face2, floor]  # faces 4-6 recede
    np.testing.assert_allclose(delta, expected, rtol=1e-12, atol=1e-12)
    unit = reach.nominal_erosion(np.array([[50.0, 100.0, 0.0]]), CORRIDOR, w, a, unit_rows=True)
    norms = np.r_[np.full(8, 1.0 / math.cos(30.0 * DEG)), 1.0]
    np.testing.assert_allclose(unit[0], np.array(expected) / norms**2, rtol=1e-12)


def test_criterion_16_and_the_sync_bound_at_hand_points():
    w, a = 1.0 * DEG, 0.02  # r_sync = 131.3 m
    points = [
        [0.0, 100.0, 0.0],  # face 1: s = 57.7 < delta = (100 w)^2 / (2 a) = 76.2: out
        [-60.0, 120.0, 0.0],  # passes every row (by hand below) but |p| = 134.2 > r_sync
        [-20.0, 60.0, 0.0],  # passes every row and |p| = 63.2 < r_sync
    ]
    grid = _points_grid(points)
    mask = reach.certified_mask(reach.GridSlack.on(grid, CORRIDOR), w, a)
    assert (100.0 * w) ** 2 / (2.0 * a) > 100.0 * TAN  # point 0 fails on face 1
    v = w * np.array([120.0, 60.0])  # point 1: v_rot
    assert 120.0 * TAN + 60.0 > (v[0] - TAN * v[1]) ** 2 / (2.0 * a)  # face 1 passes
    assert 120.0 * TAN + 60.0 * C45 > (C45 * v[0] - TAN * v[1]) ** 2 / (2.0 * a)  # face 2 passes
    assert math.hypot(60.0, 120.0) > sync_range_m(a, w)
    assert mask.tolist() == [False, False, True]


def test_table_2_reproduced_on_the_320_m_grid(grid_terms):
    grid, terms = grid_terms
    assert np.count_nonzero(grid.inside) == 45_000  # cell centres: exactly half the grid
    ours = {
        (w, a): reach.safe_fraction(reach.certified_mask(terms, w * DEG, a), grid)
        for w, a in reach.COMBINATIONS
    }
    worst = max(abs(ours[key] - reach.PAPER_TABLE_2[key]) for key in ours)
    assert worst < 0.25, ours


# --- the tightenings and the nesting ---------------------------------------------------------


def test_double_integrator_tightenings_by_hand():
    example = reach.DoubleIntegratorExample()
    tight = example.tightenings()
    z = 2.241402727604945  # Phi^-1(1 - 0.05 / 4)
    for k in range(example.steps + 1):
        # r^T A^m = [1, m] for +-e1, [0, 1] for +-e2; the sum runs over m = 0..k-1.
        sq1 = sum(1.0 + m * m for m in range(k))
        l1_1 = sum(1.0 + m for m in range(k))
        expected_stoch = z * example.sigma_w * np.sqrt([sq1, sq1, k, k])
        expected_rob = example.w_max * np.array([l1_1, l1_1, k, k])
        np.testing.assert_allclose(tight["stochastic"][k], expected_stoch, rtol=1e-12)
        np.testing.assert_allclose(tight["robust"][k], expected_rob, rtol=1e-12)
    # N = 5: sqrt(35) and 15 on x_1, sqrt(5) and 5 on x_2.
    assert tight["stochastic"][5, 0] == pytest.approx(z * 0.02 * math.sqrt(35.0))
    assert tight["robust"][5, 0] == pytest.approx(0.06 * 15.0)
    assert np.all(tight["robust"] >= tight["stochastic"])


def test_double_integrator_sets_are_nested():
    sets = reach.DoubleIntegratorExample().safe_start_sets()
    nom, sto, rob = (sets[name] for name in ("nominal", "stochastic", "robust"))
    assert nom.area_m2 > sto.area_m2 > rob.area_m2 > 0.0
    assert np.all(reach.in_polygon(rob.vertices, sto.vertices, margin=1e-6))
    assert np.all(reach.in_polygon(sto.vertices, nom.vertices, margin=1e-6))
    x1, x2 = np.meshgrid(np.linspace(-5.0, 5.0, 81), np.linspace(-3.0, 3.0, 61))
    points = np.column_stack([x1.ravel(), x2.ravel()])
    m_nom, m_sto, m_rob = (s.contains(points) for s in (nom, sto, rob))
    assert not np.any(m_rob & ~m_sto) and not np.any(m_sto & ~m_nom)
    assert np.any(m_nom & ~m_rob)  # the tightening removes something
    # A start at full speed toward the wall cannot stop: x_2 = 3 needs 3 steps at |u| = 1 and
    # covers 4.5 m doing it, so from x_1 = 1 it passes x_1 = 5.
    assert not nom.lp.feasible([1.0, 3.0])[0] and nom.lp.feasible([0.0, 0.0])[0]


def test_noise_model_that_would_break_the_nesting_is_refused():
    z = reach.bonferroni_quantile(0.05, 9)
    assert z == pytest.approx(2.5392, abs=1e-4)
    bad = reach.NoiseModel(sigma_m_s2=1e-3, w_max_m_s2=0.9 * z * 1e-3)
    with pytest.raises(ValueError, match="not guaranteed"):
        reach.corridor_tightenings(CORRIDOR, 1.0 * DEG, bad)


def test_nesting_on_every_grid_of_all_20(grid_terms):
    grid, terms = grid_terms
    for w, a in reach.COMBINATIONS:
        sets = reach.certified_sets(terms, w * DEG, a)
        nom, sto, rob = sets["nominal"], sets["stochastic"], sets["robust"]
        assert not np.any(nom & ~grid.inside)
        assert not np.any(sto & ~nom), (w, a)
        assert not np.any(rob & ~sto), (w, a)
        if nom.sum() > 1000:
            assert rob.sum() < sto.sum() < nom.sum(), (w, a)


def test_corridor_tightenings_grow_with_the_horizon_and_respect_the_order():
    short = reach.corridor_tightenings(CORRIDOR, 2.0 * DEG, reach.NoiseModel(steps=5))
    long = reach.corridor_tightenings(CORRIDOR, 2.0 * DEG, reach.NoiseModel(steps=20))
    for family in ("stochastic", "robust"):
        assert np.all(long[family] > short[family])
    assert np.all(long["robust"] >= long["stochastic"])
    # Near a free double integrator: sigma_i ~ sigma_a |a_i| (sum_j (j + 1/2)^2)^(1/2).
    face1 = math.hypot(1.0, TAN) * 2e-3 * math.sqrt(sum((j + 0.5) ** 2 for j in range(20)))
    assert long["stochastic"][0] == pytest.approx(2.5392 * face1, rel=0.05)


# --- the backward kernel ----------------------------------------------------------------------


def test_flat_spin_model_decouples_z():
    A, B = reach.flat_spin_body_model(3.0 * DEG, N, 4, 1.0)
    plane, out = [0, 1, 3, 4], [2, 5]
    assert np.abs(A[:, plane][:, :, out]).max() < 1e-15
    assert np.abs(A[:, out][:, :, plane]).max() < 1e-15
    assert np.abs(B[:, plane][:, :, 2]).max() < 1e-15


def _simulate_in_lvlh(p_T, v_T, U, omega_t, steps, dt=1.0, phase0=0.0) -> np.ndarray:
    """Positions in T (steps + 1, 3) from CW propagated in L (eqs. 5-6), independently of the
    body-frame composition: T = R_z(phase0 + (omega_t - n) t) L, w_LT = [0, 0, omega_t - n]."""
    rate = omega_t - N

    def R_LT(t):
        c, s = math.cos(phase0 + rate * t), math.sin(phase0 + rate * t)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    w = np.array([0.0, 0.0, rate])
    x = np.concatenate([R_LT(0.0) @ p_T, R_LT(0.0) @ (v_T + np.cross(w, p_T))])
    Phi, Bd = cw_state_transition(N, dt), cw_zoh_input(N, dt)
    positions = [R_LT(0.0).T @ x[:3]]
    for k in range(steps):
        x = Phi @ x + Bd @ np.array([U[2 * k], U[2 * k + 1], 0.0])
        positions.append(R_LT((k + 1) * dt).T @ x[:3])
    return np.array(positions)


@pytest.mark.parametrize("start", ["corotating", "inertial"])
def test_a_kernel_point_has_a_sequence_that_keeps_it_inside(start):
    w, a = 3.0 * DEG, 0.2
    polygon = reach.backward_kernel_polygon(CORRIDOR, w, a, start=start)
    # A point 1 cm inside the kernel's longest edge that is not the cone's or the cut's.
    V = polygon.vertices
    edges = np.roll(V, -1, axis=0) - V
    longest = np.argsort(-np.linalg.norm(edges, axis=1))
    for k in longest:
        mid = V[k] + 0.5 * edges[k]
        inward = np.array([-edges[k][1], edges[k][0]]) / np.linalg.norm(edges[k])
        p = mid + 0.01 * inward
        if np.min(CORRIDOR.slack(np.r_[p, 0.0])) > 1.0 and p[1] < reach.GRID_Y_MAX_M - 1.0:
            break
    else:
        pytest.fail("no interior edge")
    assert polygon.contains(p[None])[0]
    feasible, U = polygon.lp.feasible(p)
    assert feasible
    assert np.abs(U).max() <= a + 1e-9
    v0 = w * np.array([p[1], -p[0]]) if start == "inertial" else np.zeros(2)  # eq. 13's v_rot
    path = _simulate_in_lvlh(np.r_[p, 0.0], np.r_[v0, 0.0], U, w, 20)
    assert np.min(CORRIDOR.slack(path)) > -1e-6
    # The same inputs on the nonlinear two-body map of Sec. 4.4 (rpod.planners.los_prediction)
    # stay inside too: CW's linearisation error is ~1e-5 m here (the point is 1 cm in).
    step = BodyFrameStep(1.0, "two_body", np.diag([100.0, 120.0, 150.0]))
    target = reach.flat_spin_targets(w, N, 0, 1.0)[0]
    x = np.r_[p, 0.0, v0, 0.0]
    worst = np.min(CORRIDOR.slack(x[:3]))
    for k in range(20):
        x = step.step(target, x, np.r_[U[2 * k : 2 * k + 2], 0.0])
        target = step.target_next(target)
        worst = min(worst, np.min(CORRIDOR.slack(x[:3])))
    assert worst > -1e-4
    # ...and the point 1 cm outside the same edge has none.
    q = mid - 0.01 * inward
    assert not polygon.contains(q[None])[0]
    assert not polygon.lp.feasible(q)[0]


def test_a_point_outside_the_kernel_has_no_sequence():
    w, a = 3.0 * DEG, 0.2
    polygon = reach.backward_kernel_polygon(CORRIDOR, w, a, start="inertial")
    p = np.array([0.9 * TAN * 250.0, 250.0])  # in the cone, near face 1, far out
    assert CORRIDOR.contains(np.r_[p, 0.0])
    assert not polygon.contains(p[None])[0]
    assert not polygon.lp.feasible(p)[0]
    lp = polygon.lp  # independently: HiGHS on the same LP with p fixed says infeasible
    result = linprog(
        np.zeros(lp.H.shape[1]),
        A_ub=lp.H,
        b_ub=lp.g - lp.F @ p,
        bounds=[(-a, a)] * lp.H.shape[1],
        method="highs",
    )
    assert result.status == 2
    # Coasting from there (U = 0) leaves through face 1 within the horizon.
    path = _simulate_in_lvlh(np.r_[p, 0.0], np.r_[w * p[1], -w * p[0], 0.0], np.zeros(40), w, 20)
    assert np.min(CORRIDOR.slack(path)) < 0.0


def test_polygon_membership_equals_the_per_point_lp():
    w, a = 2.0 * DEG, 0.05
    polygon = reach.backward_kernel_polygon(CORRIDOR, w, a, start="inertial")
    rng = np.random.default_rng(4)
    V = polygon.vertices
    # Points 1 mm either side of every edge's midpoint (edges over 10 cm), random cone points.
    edges = np.roll(V, -1, axis=0) - V
    V, edges = V[np.linalg.norm(edges, axis=1) > 0.1], edges[np.linalg.norm(edges, axis=1) > 0.1]
    inward = np.column_stack([-edges[:, 1], edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]
    mids = V + 0.5 * edges
    y = rng.uniform(1.0, reach.GRID_Y_MAX_M, 150)
    random = np.column_stack([rng.uniform(-1.0, 1.0, 150) * TAN * y, y])
    points = np.vstack([mids + 1e-3 * inward, mids - 1e-3 * inward, random])
    by_polygon = polygon.contains(points)
    by_lp = np.array([polygon.lp.feasible(p)[0] for p in points])
    np.testing.assert_array_equal(by_polygon, by_lp)
    assert by_polygon[: len(V)].all() and not by_polygon[len(V) : 2 * len(V)].any()


def test_kernel_without_a_cut_is_unbounded_at_low_spin():
    lp = reach.kernel_lp(CORRIDOR, 1.0 * DEG, 0.2, y_max_m=None)
    with pytest.raises(ValueError, match="support LP"):
        reach.support_polygon(lp)


def test_forward_set_inside_the_inertial_kernel(grid_terms):
    # The erosion assumes a chaser at rest in I; the kernel from that start is the exact set it
    # approximates, and the approximation is inner at the two cases of Sec. 10.2.
    grid, terms = grid_terms
    for w, a in [(1.0, 0.2), (3.0, 0.2)]:
        nominal = reach.certified_mask(terms, w * DEG, a)
        kernel = reach.backward_kernel_polygon(CORRIDOR, w * DEG, a, start="inertial")
        inside = kernel.contains(grid.points_T[:, :2])
        assert not np.any(nominal & ~inside)
        assert inside.sum() > nominal.sum()
