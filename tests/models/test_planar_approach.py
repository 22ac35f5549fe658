"""Paper 003's planar model: dynamics, eq. 10, the docking conventions, the KOS and its three
forms, and the planar_8 wrench limits, against hand values and independent computations."""

import itertools
import math

import numpy as np
import pydrake.symbolic as sym
import pytest
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from scipy.integrate import solve_ivp
from scipy.spatial import ConvexHull

from rpod.models import planar_approach as pa
from rpod.models.shapes import ConvexPolytope, separation_distance
from rpod.models.thrusters import planar_8, wrench_matrix

GEOMETRY = pa.KeepOutGeometry(chaser_side_m=0.3, target_side_m=0.3)


# ------------------------------------------------------------------------------- dynamics


def test_euler_step_by_hand():
    x = np.array([1.0, 2.0, 0.5, 0.1, -0.2, 0.03])
    F = np.array([0.5, -1.0, 0.015])
    expected = [1.01, 1.98, 0.503, 0.105, -0.21, 0.04]  # m = 10 kg, I = 0.15 kg m^2, dt = 0.1 s
    np.testing.assert_allclose(pa.euler_step(x, F, 0.1, 10.0, 0.15), expected, rtol=0, atol=1e-15)


def test_euler_step_takes_autodiff_and_its_jacobian_is_i_plus_dt_a():
    x = InitializeAutoDiff(np.array([1.0, 2.0, 0.5, 0.1, -0.2, 0.03, 0.5, -1.0, 0.015]))[:, 0]
    out = pa.euler_step(x[:6], x[6:], 0.1, 10.0, 0.15)
    J = ExtractGradient(out)
    expected = np.zeros((6, 9))
    expected[:, :6] = np.eye(6)
    expected[[0, 1, 2], [3, 4, 5]] = 0.1
    expected[[3, 4, 5], [6, 7, 8]] = 0.1 / np.array([10.0, 10.0, 0.15])
    np.testing.assert_allclose(J, expected, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ExtractValue(out).ravel(), [1.01, 1.98, 0.503, 0.105, -0.21, 0.04])


def test_zoh_step_matches_a_tight_integration_of_eq_2():
    # The exact step against DOP853 at rtol 1e-12 (eq. 2 is a double integrator: ~1e-13).
    x = np.array([1.0, 2.0, 0.5, 0.1, -0.2, 0.03])
    F = np.array([0.5, -1.0, 0.015])
    sol = solve_ivp(
        lambda t, y: pa.planar_derivative(y, F, 10.0, 0.15),
        (0.0, 0.7),
        x,
        method="DOP853",
        rtol=1e-12,
        atol=1e-14,
    )
    np.testing.assert_allclose(pa.zoh_step(x, F, 0.7, 10.0, 0.15), sol.y[:, -1], atol=1e-11)


# --------------------------------------------------------------------- eq. 10, conventions


@pytest.mark.parametrize(
    "l_s, l_t, expected",
    [
        (0.3, 0.3, 0.3 * math.sqrt(2.0) + 0.03),  # 0.45426 m: Sec. V-A's target, equal chaser
        (0.2, 0.5, 0.35 * math.sqrt(2.0) + 0.02),
    ],
)
def test_r_safe_of_eq_10(l_s, l_t, expected):
    assert pa.r_safe(l_s, l_t) == pytest.approx(expected, rel=1e-15)
    assert pa.KeepOutGeometry(l_s, l_t).r_safe_m == pytest.approx(expected, rel=1e-15)


def test_derived_geometry_by_hand():
    g = GEOMETRY
    assert g.margin_m == pytest.approx(0.03)
    assert g.contact_distance_m == pytest.approx(0.3)
    assert g.r_relaxed_m == pytest.approx(0.33)
    assert g.ellipse_semi_axes_m == pytest.approx((0.4542640687, 0.2271320344))
    assert g.ellipse_offset_m == pytest.approx(0.2271320344 + 0.03)
    assert g.switch_distance_m == pytest.approx(1.5 * 0.4542640687)
    assert math.degrees(g.switch_angle_rad) == pytest.approx(math.degrees(math.atan(0.9)))
    assert g.default_goal_standoff_m == pytest.approx(0.36)


def test_the_switch_angle_is_the_diagonal_without_margin():
    # alpha = atan((H - l_margin) / H) -> pi / 4 (corner to corner, eq. 10) as l_margin -> 0:
    # compare a chaser 100x smaller than the target with the diagonal of the contact box.
    g = pa.KeepOutGeometry(chaser_side_m=0.003, target_side_m=0.3)
    assert g.switch_angle_rad == pytest.approx(math.atan(1.0 - 0.0003 / 0.1515), rel=1e-12)
    assert g.switch_angle_rad == pytest.approx(math.pi / 4, abs=2e-3)


def test_final_attitude_faces_the_docking_face_by_the_shortest_turn():
    # theta_approach = 3 pi / 4: face to face at 7 pi / 4, i.e. -pi / 4 nearest to 0.
    assert pa.chaser_final_attitude(0.75 * math.pi, 0.0) == pytest.approx(-0.25 * math.pi)
    assert pa.chaser_final_attitude(0.75 * math.pi, 5.0) == pytest.approx(1.75 * math.pi)
    # The chaser's +x axis is then anti-parallel to the docking normal.
    theta = pa.chaser_final_attitude(0.3, 1.0)
    x_axis = np.array([math.cos(theta), math.sin(theta)])
    assert x_axis @ pa.docking_normal(0.3) == pytest.approx(-1.0)


def test_goal_and_normal_and_target_frame():
    np.testing.assert_allclose(pa.goal_position(0.5 * math.pi, 0.36), [0.0, 0.36], atol=1e-16)
    np.testing.assert_allclose(pa.docking_normal(math.pi), [-1.0, 0.0], atol=1e-15)
    assert pa.target_attitude(10.0, 0.2, 0.1) == pytest.approx(1.2)
    # A point on the docking normal has y_T = 0 and x_T = its distance.
    x_T, y_T = pa.to_target_frame(0.4 * pa.docking_normal(2.0), 2.0)
    assert (x_T, y_T) == pytest.approx((0.4, 0.0), abs=1e-15)


# -------------------------------------------------------------------------- the KOS, q


@pytest.mark.parametrize(
    "p_T, state, q",
    [
        # On the docking normal inside r_safe: State II, the relaxed half-disc is the nearest
        # piece (0.40 - 0.33); in State I the disc would forbid it (0.40 - 0.454).
        ((0.40, 0.0), pa.STATE_II, 0.07),
        # Behind the target: State I, inside the disc.
        ((-0.40, 0.0), pa.STATE_I, 0.40 - 0.4542640687),
        # Square to the normal at 0.5 m: State I; the E+ half-ellipse's edge is nearest:
        # e = ((0.5 - c) / b)^2, q = (sqrt(e) - 1) b = 0.5 - c - b.
        ((0.0, 0.5), pa.STATE_I, 0.5 - 0.2571320344 - 0.2271320344),
        # Far on the normal: State I, q from E+ (sqrt(e) - 1) b.
        ((0.70, 0.0), pa.STATE_I, None),
        # Inside the target: negative in either state.
        ((0.2, 0.0), pa.STATE_II, 0.2 - 0.33),
        # The target centre, on the seam of State II's two half-discs: inside.
        ((0.0, 0.0), pa.STATE_II, -0.4542640687),
    ],
)
def test_q_by_hand(p_T, state, q):
    p_T = np.array(p_T)
    assert int(GEOMETRY.state(p_T)) == state
    if q is None:
        a, b = GEOMETRY.ellipse_semi_axes_m
        e = (p_T[0] / a) ** 2 + (GEOMETRY.ellipse_offset_m / b) ** 2
        q = (math.sqrt(e) - 1.0) * b
    assert float(GEOMETRY.q(p_T)) == pytest.approx(q, abs=1e-9)


def test_the_wings_stand_out_beyond_r_safe():
    # (0.4, 0.3) is 0.5 m from the centre (outside the disc), inside E+: forbidden in both
    # states; it is in the switching region (36.9 deg, 0.5 m).
    p_T = np.array([0.4, 0.3])
    assert np.hypot(*p_T) > GEOMETRY.r_safe_m
    assert GEOMETRY.q_state(p_T, pa.STATE_I) < 0 and GEOMETRY.q_state(p_T, pa.STATE_II) < 0
    assert GEOMETRY.state_i_extent_m == pytest.approx(0.5427, abs=1e-4)


@pytest.mark.parametrize(
    "p_T, state",
    [
        ((0.5, 0.0), pa.STATE_II),
        ((0.3, -0.2), pa.STATE_II),  # 33.7 deg, 0.36 m
        ((0.5, 0.5), pa.STATE_I),  # 45 deg: beyond alpha = 42 deg
        ((0.69, 0.0), pa.STATE_I),  # beyond 1.5 r_safe = 0.681 m
        ((-0.3, 0.0), pa.STATE_I),  # behind
    ],
)
def test_switching(p_T, state):
    assert int(GEOMETRY.state(np.array(p_T))) == state


def test_the_zone_turns_with_the_target():
    theta_t = 0.5 * math.pi  # the docking normal points along world +y
    p_W = np.array([0.0, 0.4])
    p_T = np.array(pa.to_target_frame(p_W, theta_t))
    assert int(GEOMETRY.state(p_T)) == pa.STATE_II
    assert float(GEOMETRY.q(p_T)) == pytest.approx(0.07, abs=1e-12)


def test_state_ii_zone_is_inside_state_i_zone():
    # Relaxing never forbids a point that State I allows (so a switch cannot trap the chaser).
    p = np.random.default_rng(1).uniform(-0.8, 0.8, (100_000, 2))
    q1, q2 = GEOMETRY.q_state(p, pa.STATE_I), GEOMETRY.q_state(p, pa.STATE_II)
    assert np.all(q2[q1 >= 0] >= 0)


def test_an_aligned_chaser_outside_the_zone_never_overlaps_the_target():
    # Aligned (final attitude, faces parallel): overlap iff |x_T| < H and |y_T| < H.
    grid = np.linspace(-0.8, 0.8, 801)
    p = np.stack(np.meshgrid(grid, grid), axis=-1).reshape(-1, 2)
    allowed = GEOMETRY.q(p) >= 0
    H = GEOMETRY.contact_distance_m
    overlap = (np.abs(p[:, 0]) < H) & (np.abs(p[:, 1]) < H)
    assert not np.any(allowed & overlap)


def test_any_attitude_is_safe_outside_state_i_and_state_ii_cannot_be_left_sideways():
    grid = np.linspace(-0.8, 0.8, 801)
    p = np.stack(np.meshgrid(grid, grid), axis=-1).reshape(-1, 2)
    # Outside r_safe two squares cannot touch whatever their attitudes (eq. 10).
    assert GEOMETRY.r_safe_m > (GEOMETRY.chaser_side_m + GEOMETRY.target_side_m) / math.sqrt(2)
    # Allowed points inside r_safe (State II) have bearings well below alpha.
    inside = (GEOMETRY.q(p) >= 0) & (np.hypot(p[:, 0], p[:, 1]) < GEOMETRY.r_safe_m)
    assert inside.any()
    assert GEOMETRY.bearing_rad(p[inside]).max() < 0.6 * GEOMETRY.switch_angle_rad


def test_face_heading_error_by_hand():
    # Facing the face: the chaser's +x along -n, theta_c = theta_t + pi (any 2 pi multiple).
    assert float(pa.face_heading_error(1.0 + math.pi, 1.0)) == pytest.approx(0.0, abs=1e-15)
    assert float(pa.face_heading_error(1.0 - math.pi + 0.1, 1.0)) == pytest.approx(0.1)
    assert float(pa.face_heading_error(0.0, 0.0)) == pytest.approx(-math.pi)


def test_state_ii_needs_the_heading_on_the_face():
    p_T = np.array([0.40, 0.0])  # in the switching region, inside r_safe
    tolerance = GEOMETRY.alignment_tolerance_rad
    assert tolerance == pytest.approx(math.radians(3.0))
    assert int(GEOMETRY.state(p_T, 0.0)) == pa.STATE_II
    assert int(GEOMETRY.state(p_T, -0.99 * tolerance)) == pa.STATE_II
    assert int(GEOMETRY.state(p_T, 1.01 * tolerance)) == pa.STATE_I
    assert int(GEOMETRY.state(p_T, 2.0 * math.pi)) == pa.STATE_II  # wrapped
    assert float(GEOMETRY.q(p_T, 0.0)) == pytest.approx(0.07, abs=1e-12)
    assert float(GEOMETRY.q(p_T, 0.5)) == pytest.approx(0.40 - GEOMETRY.r_safe_m, abs=1e-12)


def test_squares_gap_agrees_with_the_polytope_separation():
    rng = np.random.default_rng(5)
    p_T = rng.uniform(-0.6, 0.6, (300, 2))
    phi = rng.uniform(-math.pi, math.pi, 300)
    gap = pa.squares_gap(p_T, phi, 0.3, 0.3)
    target = ConvexPolytope.box([0.3, 0.3, 0.3])
    for k in range(len(p_T)):
        c, s = math.cos(phi[k] + math.pi), math.sin(phi[k] + math.pi)
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        distance = separation_distance(
            target, np.eye(3), np.zeros(3), target, R, np.array([*p_T[k], 0.0])
        )
        # Separating axes: positive iff apart, and never more than the distance.
        assert (gap[k] > 1e-9) == (distance > 1e-9)
        assert gap[k] <= distance + 1e-9


def test_a_chaser_within_the_tolerance_never_overlaps_the_target_in_state_ii():
    # The allowed State II region (q >= 0, in the cone, within 1.5 r_safe), the heading up to
    # the tolerance off the face: the squares keep > 5 mm apart (module docstring: 8.7 mm);
    # at 3x the tolerance they would touch.
    rng = np.random.default_rng(6)
    r = rng.uniform(0.0, GEOMETRY.switch_distance_m, 400_000)
    bearing = rng.uniform(-GEOMETRY.switch_angle_rad, GEOMETRY.switch_angle_rad, len(r))
    p = np.column_stack([r * np.cos(bearing), r * np.sin(bearing)])
    p = p[GEOMETRY.q_state(p, pa.STATE_II) >= 0]
    tolerance = GEOMETRY.alignment_tolerance_rad
    for phi in np.linspace(-tolerance, tolerance, 7):
        assert pa.squares_gap(p, np.full(len(p), phi), 0.3, 0.3).min() > 0.005
    assert pa.squares_gap(p, np.full(len(p), 3.0 * tolerance), 0.3, 0.3).min() < 0.0


# -------------------------------------------------------------- the KOS, the other forms


@pytest.mark.parametrize("state", [pa.STATE_I, pa.STATE_II])
def test_polygons_circumscribe_the_exact_pieces(state):
    p = np.random.default_rng(2).uniform(-0.8, 0.8, (100_000, 2))
    q = GEOMETRY.q_state(p, state)
    outside = np.ones(len(p), dtype=bool)
    for normals, offsets in GEOMETRY.pieces(state):
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0)
        outside &= (p @ normals.T - offsets).max(axis=1) >= 0
    assert not np.any(outside & (q < 0))  # a convex restriction: never lets a point in
    assert not np.any(~outside & (q > 3e-4))  # at most 0.25 mm larger (48 facets per half)


def test_smooth_terms_are_conservative_and_scalar_generic():
    p = np.random.default_rng(3).uniform(-0.8, 0.8, (50_000, 2))
    for state in (pa.STATE_I, pa.STATE_II):
        terms = np.array(pa.keepout_smooth_terms(p.T, 0.0, GEOMETRY, state))
        ok = np.all(terms >= 0, axis=0)
        assert not np.any(ok & (GEOMETRY.q_state(p, state) < 0))
        if state == pa.STATE_II:  # II's terms include the switching region
            assert not np.any(ok & (GEOMETRY.state(p) != pa.STATE_II))
    # Float, AutoDiffXd and Expression give the same numbers.
    point, theta_t = np.array([0.35, 0.31]), 0.4
    floats = pa.keepout_smooth_terms(point, theta_t, GEOMETRY, pa.STATE_I)
    ad = InitializeAutoDiff(point)[:, 0]
    autodiff = [t.value() for t in pa.keepout_smooth_terms(ad, theta_t, GEOMETRY, pa.STATE_I)]
    a, b = sym.Variable("a"), sym.Variable("b")
    expressions = pa.keepout_smooth_terms(np.array([a, b]), theta_t, GEOMETRY, pa.STATE_I)
    env = {a: point[0], b: point[1]}
    symbolic = [e.Evaluate(env) for e in expressions]
    np.testing.assert_allclose(autodiff, floats, rtol=1e-14)
    np.testing.assert_allclose(symbolic, floats, rtol=1e-14)


# -------------------------------------------------------------------------- wrench limits


def test_planar_8_limits_by_hand():
    # Two thrusters push along each body axis, four turn each way at s / 2.
    assert pa.planar_8_wrench_limits(0.3, 0.3) == pytest.approx((0.6, 0.18))
    assert pa.planar_8_wrench_limits(0.5, 0.03) == pytest.approx((0.06, 0.03))


def test_the_coupled_limit_is_exactly_the_planar_8_wrench_set():
    side, thrust = 0.3, 0.3
    fmax, tmax = pa.planar_8_wrench_limits(side, thrust)
    B = wrench_matrix(planar_8(side_m=side, max_thrust_N=thrust))[[3, 4, 2]]  # f_x, f_y, tau
    vertices = np.array([B @ u for u in itertools.product((0.0, 1.0), repeat=8)])
    # Every reachable wrench is inside, and the limit is attained (the hull touches it).
    excess = pa.body_wrench_excess(vertices, fmax, tmax)
    assert excess.max() == pytest.approx(0.0, abs=1e-12)
    # Random wrenches: inside the hull iff within the limit (points near the surface skipped).
    hull = ConvexHull(vertices)
    w = np.random.default_rng(4).uniform(-1.0, 1.0, (20_000, 3)) * [fmax, fmax, tmax] * 1.2
    in_hull = np.all(w @ hull.equations[:, :3].T + hull.equations[:, 3] <= 0, axis=1)
    e = pa.body_wrench_excess(w, fmax, tmax)
    clear = np.abs(e) > 1e-9
    assert np.array_equal(in_hull[clear], e[clear] < 0)
    # The box alone lets corners through that planar_8 cannot make.
    corner = np.array([fmax, fmax, tmax])
    assert pa.body_wrench_excess(corner, fmax, tmax, coupled=False) == pytest.approx(0.0)
    assert pa.body_wrench_excess(corner, fmax, tmax) > 0


def test_body_wrench_rotates_the_force_into_the_chaser():
    fx, fy, tau = pa.body_wrench(0.5 * math.pi, np.array([1.0, 0.0, 0.2]))
    assert (fx, fy, tau) == pytest.approx((0.0, -1.0, 0.2), abs=1e-15)
