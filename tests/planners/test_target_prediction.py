"""Tests for rpod.planners.target_prediction against conservation laws, closed forms and an
independent integration (a rotation-matrix state instead of a quaternion)."""

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RollPitchYaw, RotationMatrix
from scipy.integrate import solve_ivp

from rpod.models.rigid_body import axisymmetric_torque_free_solution
from rpod.planners.target_prediction import TargetPrediction, predict_target

# Paper 000 eq. (27), the target inertia [kg m^2].
J_PAPER = np.array([[5.89056, 0.0, 0.0], [0.0, 11.4462, 0.233516], [0.0, 0.233516, 11.5365]])
N_TABLE_I = np.sqrt(3.986004418e14 / 7738e3**3)  # mean motion for Table I's a = 7738 km [rad/s]
# 10 deg/s, the paper's largest tumble rate, about a non-principal axis.
W_10DEG = np.radians(10.0) * np.array([0.6, 0.5, -0.62]) / np.linalg.norm([0.6, 0.5, -0.62])
Q_LT0 = RollPitchYaw(0.4, -1.1, 2.0).ToQuaternion().wxyz()


def _R(q_wxyz) -> np.ndarray:
    q = np.asarray(q_wxyz, dtype=float)
    return RotationMatrix(Quaternion(q / np.linalg.norm(q))).matrix()


def _angle(R1, R2) -> float:
    """Angle of R1^T R2 [rad], from its skew part (accurate for small angles)."""
    S = R1.T @ R2
    return float(np.linalg.norm([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]]) / 2)


def _reference(q_LT0, w0, J, n_orbit, t0, t_eval):
    """Independent dense integration: state (R_I'T as 9 entries, w_IT_T), R_dot = R [w]x.

    Shares nothing with the code under test but scipy's DOP853: no quaternions, no Hermite
    splines, and the LVLH turn applied as a matrix product Rz(-n (t - t0)) R_I'T.
    """
    J_inv = np.linalg.inv(J)

    def rhs(_t, state):
        R, w = state[:9].reshape(3, 3), state[9:]
        w_hat = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        return np.concatenate([(R @ w_hat).ravel(), J_inv @ np.cross(J @ w, w)])

    solution = solve_ivp(
        rhs,
        (t0, t_eval[-1]),
        np.concatenate([_R(q_LT0).ravel(), w0]),
        method="DOP853",
        t_eval=t_eval,
        rtol=1e-13,
        atol=1e-13,
    )
    R_LT = [
        RotationMatrix.MakeZRotation(-n_orbit * (t - t0)).matrix() @ y[:9].reshape(3, 3)
        for t, y in zip(solution.t, solution.y.T)
    ]
    return np.array(R_LT), solution.y[9:].T


def test_torque_free_energy_and_momentum_are_conserved():
    # 350 s at 10 deg/s with the LVLH turn on. DOP853 at rtol = atol = 1e-12 over ~200 steps
    # keeps the global error ~1e-11 (observed: energy 1.3e-12, momentum 8.6e-12 relative);
    # 1e-10 relative is the stated bound.
    # Momentum is constant in the inertial frame I' = L(t0): h = Rz(n tau) R_LT J w.
    t = np.arange(0.0, 351.0)
    prediction = predict_target(Q_LT0, W_10DEG, J_PAPER, t, n_orbit=N_TABLE_I)
    w = prediction.w_IT_T
    energy = 0.5 * np.einsum("ki,ij,kj->k", w, J_PAPER, w)
    np.testing.assert_allclose(energy, energy[0], rtol=1e-10)
    h_I = np.array(
        [
            RotationMatrix.MakeZRotation(N_TABLE_I * tk).matrix() @ _R(q) @ J_PAPER @ wk
            for tk, q, wk in zip(t, prediction.q_LT, w)
        ]
    )
    np.testing.assert_allclose(
        h_I, np.tile(h_I[0], (len(t), 1)), atol=1e-10 * np.linalg.norm(h_I[0])
    )
    np.testing.assert_allclose(np.linalg.norm(prediction.q_LT, axis=1), 1.0, atol=1e-15)
    # The prediction starts exactly at the estimate.
    np.testing.assert_allclose(prediction.q_LT[0], Q_LT0, atol=1e-15)
    np.testing.assert_array_equal(prediction.w_IT_T[0], W_10DEG)


@pytest.mark.parametrize("n_orbit", [0.0, N_TABLE_I, 0.05])
def test_axisymmetric_target_matches_closed_form(n_orbit):
    # J = diag(J_t, J_t, J_a) has a closed-form torque-free motion (rpod.models.rigid_body);
    # with the LVLH turn, R_LT(t) = Rz(-n t) R_closed(t). DOP853 at 1e-12: 1e-11 rad and
    # 1e-14 rad/s observed; bounds 1e-9 rad and 1e-11 rad/s.
    J_t, J_a = 9.0, 5.0
    w0 = np.radians([4.0, -6.0, 7.0])
    t = np.linspace(0.0, 200.0, 101)
    prediction = predict_target(Q_LT0, w0, np.diag([J_t, J_t, J_a]), t, n_orbit=n_orbit)
    q_closed, w_closed = axisymmetric_torque_free_solution(J_t, J_a, w0, Q_LT0, t)
    for tk, q, q_ref in zip(t, prediction.q_LT, q_closed):
        R_ref = RotationMatrix.MakeZRotation(-n_orbit * tk).matrix() @ _R(q_ref)
        assert _angle(_R(q), R_ref) < 1e-9
    np.testing.assert_allclose(prediction.w_IT_T, w_closed, atol=1e-11)


def test_interpolation_exact_at_knots_and_fourth_order_between():
    # Knots every h = 1 s (the planner's dt) from t0 = 5 s, at 10 deg/s, with the LVLH turn.
    t0, h = 5.0, 1.0
    knots = t0 + np.arange(0.0, 61.0) * h
    prediction = predict_target(Q_LT0, W_10DEG, J_PAPER, knots, n_orbit=N_TABLE_I)
    for k in (0, 17, 60):
        assert _angle(prediction.R_LT(knots[k]), _R(prediction.q_LT[k])) < 1e-15
        np.testing.assert_allclose(prediction.w_IT_T_at(knots[k]), prediction.w_IT_T[k], atol=1e-16)

    def errors(knot_step):
        coarse = predict_target(
            Q_LT0, W_10DEG, J_PAPER, t0 + np.arange(0.0, 61.0, knot_step), n_orbit=N_TABLE_I
        )
        between = t0 + np.arange(0.0, 60.0, knot_step)[:, None] + knot_step * np.array([0.25, 0.5])
        between = between.ravel()
        R_ref, w_ref = _reference(Q_LT0, W_10DEG, J_PAPER, N_TABLE_I, t0, between)
        angle = max(_angle(coarse.R_LT(tk), R) for tk, R in zip(between, R_ref))
        rate = max(np.abs(coarse.w_IT_T_at(tk) - w).max() for tk, w in zip(between, w_ref))
        return angle, rate

    angle_1, rate_1 = errors(h)
    angle_2, rate_2 = errors(2.0 * h)
    # Cubic Hermite with exact slopes: error <= h^4 / 384 max |q''''| ~ h^4 (|w|/2)^4 / 384
    # ~ 1.5e-7 in the quaternion, ~3e-7 rad in angle (observed 3.0e-7 rad; a slerp through the
    # same knots errs by 1.0e-3 rad here). Rates: observed 6.8e-9 rad/s. Tolerances 1e-6 rad
    # and 1e-7 rad/s; the error of the reference (~1e-11) is negligible.
    assert angle_1 < 1e-6
    assert rate_1 < 1e-7
    # Fourth order: doubling the knot step multiplies the error by ~2^4 = 16 (observed 16.0).
    assert 10.0 < angle_2 / angle_1 < 24.0
    assert 10.0 < rate_2 / rate_1 < 24.0


@pytest.mark.parametrize("n_orbit", [N_TABLE_I, 0.05])
def test_orbit_rate_turns_a_non_rotating_target_in_lvlh(n_orbit):
    # w_IT_T = 0: the target is inertially fixed, so in LVLH R_LT(t) = Rz(-n t) R_LT0. At the
    # knots this is exact to round-off; between them the Hermite error is below
    # (n h / 2)^4 / 384 ~ 2e-8 at the exaggerated n = 0.05 rad/s and h = 2 s (observed 2e-10
    # rad). Tolerance 1e-7 rad.
    knots = np.arange(0.0, 301.0, 2.0)
    prediction = predict_target(Q_LT0, np.zeros(3), J_PAPER, knots, n_orbit=n_orbit)
    for tk in np.concatenate([knots[::15], knots[:-1:15] + 0.7]):
        expected = RotationMatrix.MakeZRotation(-n_orbit * tk).matrix() @ _R(Q_LT0)
        assert _angle(prediction.R_LT(tk), expected) < 1e-7
        np.testing.assert_array_equal(prediction.w_IT_T_at(tk), np.zeros(3))
    np.testing.assert_array_equal(prediction.w_IT_T, np.zeros((len(knots), 3)))


def test_rejects_bad_inputs_and_out_of_span_queries():
    knots = np.arange(0.0, 11.0)
    prediction = predict_target(Q_LT0, W_10DEG, J_PAPER, knots)
    with pytest.raises(ValueError, match="outside"):
        prediction.R_LT(10.5)
    with pytest.raises(ValueError, match="outside"):
        prediction.w_IT_T_at(-0.1)
    with pytest.raises(ValueError, match="q_LT0"):
        predict_target([0.0, 0.0, 0.0, 0.0], W_10DEG, J_PAPER, knots)
    with pytest.raises(ValueError, match="w_IT_T0"):
        predict_target(Q_LT0, [np.nan, 0.0, 0.0], J_PAPER, knots)
    with pytest.raises(ValueError, match="triangle"):
        predict_target(Q_LT0, W_10DEG, np.diag([1.0, 1.0, 3.0]), knots)
    with pytest.raises(ValueError, match="increasing"):
        predict_target(Q_LT0, W_10DEG, J_PAPER, [0.0, 2.0, 1.0])
    with pytest.raises(ValueError, match="increasing"):
        TargetPrediction(t=[0.0], q_LT=[Q_LT0], w_IT_T=[W_10DEG], inertia=J_PAPER)
