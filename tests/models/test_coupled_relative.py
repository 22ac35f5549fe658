"""Tests of rpod.models.coupled_relative (paper 001's coupled 6-DOF prediction model).

Independent references: AutoDiffXd against central finite differences; the relative state
integrated by scipy against both bodies integrated separately (quaternions and Euler's equations
of rpod.models.rigid_body, two-body orbits of rpod.models.gravity) and recombined with the
feature points' lever arms by hand; np.cross sums for the thruster wrench; the uniform cuboid for
the inertia; pydrake's AngleAxis for the eigenaxis error; the paper's printed initial state.
"""

import math

import numpy as np
import pytest
import scipy.integrate
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RollPitchYaw, RotationMatrix
from scipy.integrate import solve_ivp

from rpod.models import coupled_relative as cr
from rpod.models.frames import skew
from rpod.models.gimbal import wrench_from_forces
from rpod.models.gravity import (
    MU_EARTH_M3_S2,
    circular_orbit_state,
    two_body_acceleration,
)
from rpod.models.rigid_body import angular_acceleration, quaternion_rate

# A non-isotropic target so that its tumble (and the relative rate) is not a steady spin.
J_TARGET = np.diag([2.0e6, 3.1e6, 3.9e6])


def _params() -> cr.CoupledRelativeParams:
    return cr.CoupledRelativeParams(J_t=J_TARGET)


def _rotation(rpy) -> np.ndarray:
    return RotationMatrix(RollPitchYaw(rpy)).matrix()


def _absolute_start(chaser_rate=(0.01, -0.02, 0.015)):
    """Both bodies' absolute states: a tumbling target at 300 km, a chaser ~100 m away."""
    p_IT_I, v_IT_I = circular_orbit_state(cr.TARGET_ALTITUDE_M, 0.9, 0.3, 0.2)
    R_IT = _rotation([0.3, -0.2, 1.1])
    w_IT_T = np.array([0.03, -0.02, 0.025])
    R_IC = _rotation([2.0, 0.4, -0.7])
    w_IC_C = np.array(chaser_rate, dtype=float)
    p_IC_I = p_IT_I + np.array([30.0, -80.0, 45.0])
    v_IC_I = v_IT_I + np.array([0.05, 0.12, -0.08])
    return R_IT, w_IT_T, p_IT_I, v_IT_I, R_IC, w_IC_C, p_IC_I, v_IC_I


def _state_and_input():
    params = _params()
    x = cr.relative_state_from_absolute(params, *_absolute_start(), xi_T=[3.0, -2.0, 5.0])
    u = np.random.default_rng(1).uniform(-15.0, 15.0, cr.INPUT_SIZE)
    return params, x, u


# ----------------------------------------------------------------------------- (a) derivatives


def test_autodiff_jacobian_equals_central_differences():
    params, x, u = _state_and_input()
    z = np.concatenate([x, u])
    z_ad = InitializeAutoDiff(z)[:, 0]
    f_ad = cr.dynamics(z_ad[: cr.STATE_SIZE], z_ad[cr.STATE_SIZE :], params)
    # Same values up to the summation order of BLAS (float) and object matmuls.
    np.testing.assert_allclose(
        ExtractValue(f_ad)[:, 0], cr.dynamics(x, u, params), rtol=1e-14, atol=1e-16
    )
    J_ad = ExtractGradient(f_ad)

    # Step 1e-5 relative (1e-5 absolute below 1): truncation ~h^2 f''' ~ 1e-10 relative,
    # round-off ~1e-16 |f| / h ~ 1e-11 relative; the orbit position (7e6 m) gets a 70 m step,
    # where gravity's third derivative is ~1e-25 /m^2 s^2.
    J_fd = np.empty_like(J_ad)
    for j in range(z.size):
        h = 1e-5 * max(1.0, abs(z[j]))
        zp, zm = z.copy(), z.copy()
        zp[j] += h
        zm[j] -= h
        fp = cr.dynamics(zp[: cr.STATE_SIZE], zp[cr.STATE_SIZE :], params)
        fm = cr.dynamics(zm[: cr.STATE_SIZE], zm[cr.STATE_SIZE :], params)
        J_fd[:, j] = (fp - fm) / (2.0 * h)
    # Each entry to 1e-8 of its row's largest entry (measured 2e-10): a wrong derivative (a
    # term dropped by an object-array path, a sign) would be O(1) of the entry.
    row_scale = np.max(np.abs(J_ad), axis=1, keepdims=True) + 1e-300
    assert np.max(np.abs(J_ad - J_fd) / row_scale) < 1e-8
    # The row scale hides small physical entries; check on its own scale the smallest block,
    # d p_ddot / d p_IT_I (~1e-11 /s^2: how the gravity gradient changes along the orbit),
    # measured to agree to 5e-19.
    block = (cr.V_PTPC_T_SLICE, cr.P_IT_I_SLICE)
    assert np.max(np.abs(J_ad[block])) > 1e-12
    np.testing.assert_allclose(J_fd[block], J_ad[block], rtol=0, atol=1e-17)


def test_symbolic_input_gives_the_same_values_and_input_jacobian():
    from pydrake import symbolic

    params, x, u = _state_and_input()
    u_sym = np.array([symbolic.Variable(f"u{k}") for k in range(cr.INPUT_SIZE)])
    # numpy's object loops report the FE_INVALID flag that Drake's float * Expression leaves
    # set (rpod.models.thrusters.wrench_from_forces alone shows it); the results are exact.
    with np.errstate(invalid="ignore"):
        f_sym = cr.dynamics(x, u_sym, params)
    env = dict(zip(u_sym, u))

    def value(e):  # entries that do not depend on u stay floats
        return e.Evaluate(env) if isinstance(e, symbolic.Expression) else float(e)

    f_eval = np.array([value(e) for e in f_sym])
    np.testing.assert_allclose(f_eval, cr.dynamics(x, u, params), rtol=1e-13, atol=1e-13)
    B_sym = symbolic.Jacobian(f_sym, u_sym)
    B = np.array([[value(e) for e in row] for row in B_sym])
    u_ad = InitializeAutoDiff(u)[:, 0]
    B_ad = ExtractGradient(cr.dynamics(x, u_ad, params))
    np.testing.assert_allclose(B, B_ad, rtol=1e-13, atol=1e-16)


# ----------------------------------------------------------------------------- (b) physics

RTOL_INT = 1e-12
ATOL_INT = 1e-12
T_FINAL_S = 300.0
T_EVAL = np.linspace(0.0, T_FINAL_S, 61)


def _integrate_relative(params, x0, u):
    sol = solve_ivp(
        lambda _, x: cr.dynamics(x, u, params),
        (0.0, T_FINAL_S),
        x0,
        method="DOP853",
        t_eval=T_EVAL,
        rtol=RTOL_INT,
        atol=ATOL_INT,
        dense_output=True,
    )
    assert sol.success
    return sol


def _integrate_bodies_separately(params, start, u):
    """Target and chaser each integrated on their own: quaternion + Euler (rigid_body) and a
    two-body orbit; the chaser feels the thrusters' wrench as the np.cross sums below."""
    R_IT, w_IT_T, p_IT_I, v_IT_I, R_IC, w_IC_C, p_IC_I, v_IC_I = start
    F = u.reshape(8, 3)
    tau_C = np.sum(np.cross(params.layout.p_CK_C, F), axis=0)  # eq. 12, independently
    f_C = F.sum(axis=0)  # eq. 11
    q_T = RotationMatrix(R_IT).ToQuaternion().wxyz()
    q_C = RotationMatrix(R_IC).ToQuaternion().wxyz()

    def rhs(_, y):
        qt, wt, pt, vt = y[0:4], y[4:7], y[7:10], y[10:13]
        qc, wc, pc, vc = y[13:17], y[17:20], y[20:23], y[23:26]
        R_IC_now = RotationMatrix(Quaternion(qc / np.linalg.norm(qc))).matrix()
        return np.concatenate(
            [
                quaternion_rate(qt, wt),
                angular_acceleration(params.J_t, wt),
                vt,
                two_body_acceleration(pt, MU_EARTH_M3_S2),
                quaternion_rate(qc, wc),
                angular_acceleration(params.J_c, wc, tau_C),
                vc,
                two_body_acceleration(pc, MU_EARTH_M3_S2) + R_IC_now @ f_C / params.chaser_mass_kg,
            ]
        )

    y0 = np.concatenate([q_T, w_IT_T, p_IT_I, v_IT_I, q_C, w_IC_C, p_IC_I, v_IC_I])
    sol = solve_ivp(
        rhs, (0.0, T_FINAL_S), y0, method="DOP853", t_eval=T_EVAL, rtol=RTOL_INT, atol=ATOL_INT
    )
    assert sol.success
    return sol.y.T


def _feature_point_by_hand(params, y):
    """p_PtPc_T and its derivative seen in T from absolute states: both points' inertial
    positions and velocities (rigid-body lever arms), then into the rotating frame T."""
    qt, wt, pt, vt = y[0:4], y[4:7], y[7:10], y[10:13]
    qc, wc, pc, vc = y[13:17], y[17:20], y[20:23], y[23:26]
    R_IT = RotationMatrix(Quaternion(qt / np.linalg.norm(qt))).matrix()
    R_IC = RotationMatrix(Quaternion(qc / np.linalg.norm(qc))).matrix()
    P_c = pc + R_IC @ params.p_CPc_C
    P_t = pt + R_IT @ params.p_TPt_T
    V_c = vc + R_IC @ np.cross(wc, params.p_CPc_C)
    V_t = vt + R_IT @ np.cross(wt, params.p_TPt_T)
    p_T = R_IT.T @ (P_c - P_t)
    v_T = R_IT.T @ (V_c - V_t) - np.cross(wt, p_T)
    R_TC = R_IT.T @ R_IC
    w_TC_T = R_TC @ wc - wt
    return R_TC, w_TC_T, p_T, v_T, R_IT


@pytest.fixture(scope="module", params=["torque_free", "thrusting"])
def trajectories(request):
    params = _params()
    start = _absolute_start()
    if request.param == "torque_free":
        u = np.zeros(cr.INPUT_SIZE)
    else:  # an off-nominal, torque-producing constant thrust
        u = np.random.default_rng(7).uniform(-2.0, 2.0, cr.INPUT_SIZE)
    x0 = cr.relative_state_from_absolute(params, *start)
    relative = _integrate_relative(params, x0, u)
    return params, relative.y.T, _integrate_bodies_separately(params, start, u), relative


def test_relative_attitude_stays_on_so3(trajectories):
    _, xs, _, _ = trajectories
    for x in xs:
        s = cr.unpack_state(x)
        for R in (s.R_TC, s.R_IT):
            # DOP853 at rtol 1e-12 over ~10^3 steps: drift ~1e-10; 1e-9 asked.
            np.testing.assert_allclose(R.T @ R, np.eye(3), rtol=0, atol=1e-9)
            assert abs(np.linalg.det(R) - 1.0) < 1e-9


def test_relative_attitude_and_rate_match_two_separate_bodies(trajectories):
    params, xs, ys, _ = trajectories
    for x, y in zip(xs, ys):
        R_TC, w_TC_T, _, _, R_IT = _feature_point_by_hand(params, y)
        s = cr.unpack_state(x)
        # Two DOP853 integrations at rtol 1e-12; the thrusting chaser spins up to 0.83 rad/s
        # (40 turns in 300 s). Measured: 5e-10 (R) and 4e-10 rad/s (w), shrinking with rtol;
        # a modelling error (a sign, a missing term) shows at 1e-3 or more.
        np.testing.assert_allclose(s.R_TC, R_TC, rtol=0, atol=2e-9)
        np.testing.assert_allclose(s.R_IT, R_IT, rtol=0, atol=2e-9)
        np.testing.assert_allclose(s.w_TC_T, w_TC_T, rtol=0, atol=2e-9)


def test_feature_point_motion_matches_two_separate_orbits(trajectories):
    params, xs, ys, _ = trajectories
    for x, y in zip(xs, ys):
        _, _, p_T, v_T, _ = _feature_point_by_hand(params, y)
        s = cr.unpack_state(x)
        # The motion compared is ~100 m, with lever arms that turn by metres and differential
        # gravity of metres over 300 s; measured agreement 2e-8 m and 3e-9 m/s (rtol 1e-12 of
        # two 6.7e6 m orbits), asked to 1e-7 m and 1e-8 m/s.
        np.testing.assert_allclose(s.p_PtPc_T, p_T, rtol=0, atol=1e-7)
        np.testing.assert_allclose(s.v_PtPc_T, v_T, rtol=0, atol=1e-8)
    p_change = np.linalg.norm(xs[-1][cr.P_PTPC_T_SLICE] - xs[0][cr.P_PTPC_T_SLICE])
    assert p_change > 10.0  # the comparison is not of something that stays put


def test_integral_state_integrates_the_feature_point_position(trajectories):
    _, xs, _, relative = trajectories
    # xi(300 s) against an adaptive quadrature of p over the solver's dense output (7th order,
    # accurate to ~rtol 1e-12): agreement to 1e-9 relative of ~1e4 m s.
    xi_quad, _ = scipy.integrate.quad_vec(
        lambda t: relative.sol(t)[cr.P_PTPC_T_SLICE], 0.0, T_FINAL_S, epsrel=1e-12
    )
    np.testing.assert_allclose(xs[-1, cr.XI_T_SLICE], xi_quad, rtol=1e-9)


def test_paper_initial_feature_point_offset_is_reproduced():
    """Sec. IV: r_c/t(0), R_t/e(0) = I, R_c/e(0) = diag(-1, -1, 1) give p(0) as printed."""
    x = cr.sec_iv_initial_state()
    np.testing.assert_allclose(
        x[cr.P_PTPC_T_SLICE], [-1.1394, 113.0847, -7.6204], rtol=0, atol=0.5e-4
    )
    assert cr.eigenaxis_error(cr.unpack_state(x).R_TC) == pytest.approx(math.pi)


def test_absolute_and_relative_states_are_inverse():
    params = _params()
    start = _absolute_start()
    x = cr.relative_state_from_absolute(params, *start)
    R_IC, w_IC_C, p_IC_I, v_IC_I = cr.chaser_absolute_state(params, x)
    np.testing.assert_allclose(R_IC, start[4], atol=1e-15)
    np.testing.assert_allclose(w_IC_C, start[5], atol=1e-17)
    np.testing.assert_allclose(p_IC_I - start[2], start[6] - start[2], atol=1e-8)
    np.testing.assert_allclose(v_IC_I - start[3], start[7] - start[3], atol=1e-12)
    np.testing.assert_array_equal(cr.pack_state(cr.unpack_state(x)), x)


def test_differential_gravity_equals_the_difference_of_two_accelerations():
    p_IT_I, _ = circular_orbit_state(cr.TARGET_ALTITUDE_M, 0.9, 0.3, 0.2)
    for d in ([10.0, -50.0, 30.0], [1e-3, 0.0, 0.0], [2e3, 1e3, -3e3]):
        d = np.array(d)
        naive = two_body_acceleration(p_IT_I + d) - two_body_acceleration(p_IT_I)
        # naive loses ~1e-15 m/s^2 (ulps of 8.9 m/s^2); the form under test loses nothing.
        np.testing.assert_allclose(
            cr.differential_two_body_acceleration(p_IT_I, d), naive, rtol=0, atol=1e-14
        )


# ----------------------------------------------------------------------------- (c) wrench


def test_thrust_vectors_wrench_equals_rpods_map_and_cross_sums():
    params = cr.CoupledRelativeParams()
    rng = np.random.default_rng(3)
    for _ in range(5):
        u = rng.uniform(-20.0, 20.0, cr.INPUT_SIZE)
        F = u.reshape(8, 3)
        expected = np.concatenate([np.cross(params.layout.p_CK_C, F).sum(axis=0), F.sum(axis=0)])
        np.testing.assert_allclose(cr.chaser_wrench(params, u), expected, rtol=1e-13, atol=1e-12)
        np.testing.assert_array_equal(
            cr.chaser_wrench(params, u), wrench_from_forces(params.layout, F)
        )
    # Nominal directions: every line of thrust passes through the CoM (Sec. II-B), no torque.
    nominal = (params.layout.directions_C * cr.MAX_THRUST_N).reshape(-1)
    np.testing.assert_allclose(cr.chaser_wrench(params, nominal)[:3], 0.0, atol=1e-12)


def test_thrust_enters_the_dynamics_as_force_and_torque():
    """d f / d u from AutoDiffXd equals the wrench map pushed through eqs. 4 and 9-10."""
    params, x, u = _state_and_input()
    s = cr.unpack_state(x)
    B_ad = ExtractGradient(cr.dynamics(x, InitializeAutoDiff(u)[:, 0], params))
    P = params.layout.p_CK_C
    d_tau_du = np.hstack([skew(p) for p in P])  # eq. 12 column blocks
    d_f_du = np.hstack([np.eye(3)] * 8)  # eq. 11
    d_wdot_du = s.R_TC @ params.J_c_inv @ d_tau_du
    lever_T = s.R_TC @ params.p_CPc_C
    d_pddot_du = s.R_TC @ d_f_du / params.chaser_mass_kg - skew(lever_T) @ d_wdot_du
    np.testing.assert_allclose(B_ad[cr.W_TC_T_SLICE], d_wdot_du, rtol=1e-13, atol=1e-18)
    np.testing.assert_allclose(B_ad[cr.V_PTPC_T_SLICE], d_pddot_du, rtol=1e-12, atol=1e-18)
    others = np.delete(B_ad, np.r_[9:12, 15:18], axis=0)
    assert np.all(others == 0.0)


# ----------------------------------------------------------------------------- (d) constraints
# (eq. 16, the gimbal pyramid, is rpod.models.gimbal's: tests/models/test_gimbal.py)


def test_thrust_magnitude_limit():
    u = np.zeros(cr.INPUT_SIZE)
    u[3:6] = [12.0, 16.0, 0.0]  # exactly 20 N
    u[6:9] = [0.0, 0.0, 20.001]
    g = cr.thrust_magnitude_constraints(u)
    assert g[1] == pytest.approx(0.0, abs=1e-12)
    assert g[2] > 0.0
    assert g[0] == -400.0
    g_ad = cr.thrust_magnitude_constraints(InitializeAutoDiff(u)[:, 0])
    assert np.all(np.isfinite(ExtractGradient(g_ad)))  # smooth at f_k = 0 (choice 4)


def test_paper_inertia_is_the_uniform_cuboid():
    a, b, c = cr.CHASER_SIZE_M
    m = cr.CHASER_MASS_KG
    J = m / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    # The paper prints 5 significant digits (6.0833e3, 1.5e3).
    np.testing.assert_allclose(cr.CHASER_INERTIA_KG_M2, J, rtol=1e-5)


def test_los_polyhedron_axis_angle_and_paper_start():
    A_p = cr.los_polyhedron()
    axis = cr.TARGET_FEATURE_POINT_T_M / np.linalg.norm(cr.TARGET_FEATURE_POINT_T_M)
    x = np.zeros(cr.STATE_SIZE)
    x[cr.P_PTPC_T_SLICE] = 50.0 * axis
    assert np.all(cr.los_constraints(A_p, x) < 0.0)
    # Tilted just inside / outside each face at pi/4 about the axis.
    lateral = [-(A_p[i] + math.sin(math.pi / 4) * axis) / math.cos(math.pi / 4) for i in range(4)]
    for i, e in enumerate(lateral):
        assert abs(e @ axis) < 1e-15 and abs(np.linalg.norm(e) - 1.0) < 1e-15
        for angle, inside in ((math.pi / 4 - 1e-6, True), (math.pi / 4 + 1e-6, False)):
            x[cr.P_PTPC_T_SLICE] = 50.0 * (math.cos(angle) * axis - math.sin(angle) * e)
            assert np.all(cr.los_constraints(A_p, x) <= 0.0) == inside
    # Sec. IV's start is outside (64.7 deg off the axis): slacks make it feasible.
    p0 = np.array([-1.1394, 113.0847, -7.6204])
    assert math.degrees(math.acos(p0 @ axis / np.linalg.norm(p0))) == pytest.approx(64.7, abs=0.05)
    x[cr.P_PTPC_T_SLICE] = p0
    g = cr.los_constraints(A_p, x)
    assert np.max(g) > 0.0
    slack = np.maximum(g, 0.0)
    assert np.all(cr.los_constraints(A_p, x, slack) <= 0.0)
    assert cr.los_slack_penalty(slack) == pytest.approx(cr.LOS_SLACK_WEIGHT * slack.sum())


# ----------------------------------------------------------------------------- (e) errors, cost


def test_eigenaxis_error():
    assert cr.eigenaxis_error(np.eye(3)) == 0.0
    rng = np.random.default_rng(5)
    for _ in range(5):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        half_turn = AngleAxis(math.pi, axis).rotation()
        assert cr.eigenaxis_error(half_turn) == pytest.approx(math.pi, abs=1e-7)
        angle = rng.uniform(0.1, 3.0)
        assert cr.eigenaxis_error(AngleAxis(angle, axis).rotation()) == pytest.approx(
            angle, abs=1e-12
        )
    R_ad = InitializeAutoDiff(AngleAxis(1.0, [0.0, 0.0, 1.0]).rotation().reshape(9))[:, 0]
    assert cr.eigenaxis_error(R_ad.reshape(3, 3)).value() == pytest.approx(1.0, abs=1e-12)


def test_stage_and_terminal_costs_by_hand():
    params = cr.CoupledRelativeParams()
    weights = cr.CoupledNmpcWeights()
    theta = 0.7
    x = np.zeros(cr.STATE_SIZE)
    x[cr.R_TC_SLICE] = AngleAxis(theta, [0.6, 0.0, 0.8]).rotation().reshape(9)
    x[cr.W_TC_T_SLICE] = [0.01, 0.0, -0.02]
    x[cr.P_PTPC_T_SLICE] = [1.0, 2.0, 3.0]
    x[cr.V_PTPC_T_SLICE] = [0.1, 0.0, -0.2]
    x[cr.XI_T_SLICE] = [100.0, 0.0, 0.0]
    u = np.zeros(cr.INPUT_SIZE)
    u[0:3] = [0.0, 0.0, 2.0]  # thruster 0 at (0.75, 2, 0.75): torque (4, -1.5, 0) N m
    expected = (
        70.0 * 4.0 * math.sin(theta / 2) ** 2  # Q_R tr(I - R), D = I
        + 5.0 * (0.01**2 + 0.02**2)
        + 0.01 * 14.0
        + 1e-9 * 1e4
        + 9e-13 * (16.0 + 2.25)
        + 4.0
    )
    assert cr.stage_cost(x, u, weights, params) == pytest.approx(expected, rel=1e-13)
    Ts = cr.HORIZON_S / cr.HORIZON_INTERVALS
    expected_terminal = cr.HORIZON_S * 0.01 * (14.0 + Ts * Ts * 0.05)
    assert cr.terminal_cost(x, weights) == pytest.approx(expected_terminal, rel=1e-13)
    # Scalar-generic: d F / d u_2 = 2 W_f u_2 + 2 tau^T W_tau d tau / d u_2, with
    # d tau / d u_2 = p_0 x z = (2, -0.75, 0): 4 + 2 * 9e-13 * 9.125 (the torque term shows at
    # 4e-12 relative, so it is checked at 1e-14).
    u_ad = InitializeAutoDiff(u)[:, 0]
    grad = cr.stage_cost(x, u_ad, weights, params).derivatives()
    assert grad[2] == pytest.approx(4.0 + 2.0 * 9e-13 * 9.125, rel=1e-14, abs=0)
    assert grad[2] != pytest.approx(4.0, rel=1e-13, abs=0)
