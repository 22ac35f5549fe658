"""Tests of rpod.planners.coupled_nmpc (paper 001's OCP (22) on MathematicalProgram).

Independent references: central finite differences for the defect's AutoDiffXd Jacobian;
scipy's DOP853 (tight tolerances, `check_plan`) for the RK4 transcription; the gimbal pyramid per
thruster from rpod.models.thrusters and np.linalg.norm for the constraints.

IPOPT and SNOPT through Drake do not converge from Sec. IV's start at T = 480 s (Drake gives
them no second derivatives; coupled_nmpc's docstring): the converged solve from that start is
the SQP's, tested in tests/planners/test_coupled_sqp.py (with IPOPT confirming its optimum).
"""

import numpy as np
import pytest
from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.math import RollPitchYaw, RotationMatrix

from rpod.models import coupled_relative as cr
from rpod.models.gimbal import thruster_frame_C
from rpod.planners import coupled_nmpc as cn


def _sec_iv_start(params: cr.CoupledRelativeParams) -> np.ndarray:
    """Paper 001 Sec. IV's start (rpod.models.coupled_relative.sec_iv_initial_state)."""
    return cr.sec_iv_initial_state(params)


def _near_start(params: cr.CoupledRelativeParams) -> np.ndarray:
    """A chaser near the end of the approach: 20 m out along the LOS axis, small errors."""
    x0 = _sec_iv_start(params)
    axis = cr.TARGET_FEATURE_POINT_T_M / np.linalg.norm(cr.TARGET_FEATURE_POINT_T_M)
    x0[cr.R_TC_SLICE] = RotationMatrix(RollPitchYaw([0.1, -0.05, 0.08])).matrix().reshape(9)
    x0[cr.W_TC_T_SLICE] = [0.001, -0.002, 0.0]
    x0[cr.P_PTPC_T_SLICE] = 20.0 * axis + np.array([1.0, -0.5, 0.5])
    x0[cr.V_PTPC_T_SLICE] = [0.01, 0.0, -0.01]
    return x0


def _tilted_inputs(params, magnitude_N, tilt_rad, intervals):
    """Every thruster at magnitude_N, tilted by tilt_rad from its nominal direction (inside the
    pi/4 gimbal pyramid when tilt_rad < pi/4), varying from interval to interval."""
    u = np.zeros((intervals, cr.INPUT_SIZE))
    for k in range(intervals):
        for j, thruster in enumerate(params.layout.thrusters):
            R_CK = thruster_frame_C(thruster)  # columns: K's axes in C
            nominal = thruster.direction_C
            lateral = R_CK[:, 0] if k % 2 else R_CK[:, 2]
            lateral = lateral - (lateral @ nominal) * nominal
            lateral /= np.linalg.norm(lateral)
            f = np.cos(tilt_rad) * nominal + np.sin(tilt_rad) * lateral
            u[k, 3 * j : 3 * j + 3] = magnitude_N * f
    return u


# ------------------------------------------------------------------ (d) exact derivatives


def test_defect_autodiff_jacobian_equals_central_differences():
    params, weights = cr.CoupledRelativeParams(), cr.CoupledNmpcWeights()
    x0 = _near_start(params)
    u = _tilted_inputs(params, 8.0, 0.3, 1)[0]
    h, substeps = 60.0, 2
    x_end, q = cn.rk4_interval(x0, u, h, substeps, params, weights)
    n = cn.NLP_STATE_SIZE
    rng = np.random.default_rng(3)
    z = np.concatenate([x0[:n], u, x_end[:n] + 0.01 * rng.standard_normal(n), [q + 1.0]])
    x_target = x0[n:]

    z_ad = InitializeAutoDiff(z)[:, 0]
    d_ad = cn.interval_defect(z_ad, x_target, h, substeps, params, weights)
    d = cn.interval_defect(z, x_target, h, substeps, params, weights)
    np.testing.assert_allclose(ExtractValue(d_ad)[:, 0], d, rtol=1e-12, atol=1e-12)
    J_ad = ExtractGradient(d_ad)
    assert J_ad.shape == (cn.DEFECT_SIZE, z.size)

    # Spot check 12 columns (state, input, next state, quadrature). Step 1e-6 relative:
    # truncation ~h^2 |d'''| and round-off ~1e-16 |d| / h both ~1e-9 of a row's scale.
    for j in (0, 4, 9, 11, 13, 16, 19, 21, 30, 44, 50, 66):
        step = 1e-6 * max(1.0, abs(z[j]))
        zp, zm = z.copy(), z.copy()
        zp[j] += step
        zm[j] -= step
        column = (
            cn.interval_defect(zp, x_target, h, substeps, params, weights)
            - cn.interval_defect(zm, x_target, h, substeps, params, weights)
        ) / (2.0 * step)
        scale = np.max(np.abs(J_ad), axis=1) + 1e-12
        assert np.max(np.abs(column - J_ad[:, j]) / scale) < 1e-6, j
    # The next state and c_k enter the defect with identity / unit slope.
    np.testing.assert_array_equal(J_ad[:n, n + cr.INPUT_SIZE : 2 * n + cr.INPUT_SIZE], np.eye(n))
    assert J_ad[n, -1] == 1.0


# ------------------------------------------------------------------ the independent checker


@pytest.fixture(scope="module")
def rollout_plan():
    """A plan that satisfies the transcription exactly: the RK4 rollout of feasible inputs."""
    params = cr.CoupledRelativeParams()
    nmpc = cn.CoupledNmpc(params)
    x0 = _near_start(params)
    u = _tilted_inputs(params, 0.05, 0.5, nmpc.N)  # small: keeps the slew slow
    x, c = nmpc.rollout(x0, u)
    slack = np.maximum(x[:, cr.P_PTPC_T_SLICE] @ nmpc.A_p.T, 0.0)
    plan = cn.NmpcResult(
        status=cn.NmpcStatus.SOLVED,
        solver_message="rollout",
        u=u,
        x=x,
        slack=slack,
        stage_costs=c,
        cost=float(c.sum()),
        interval_s=nmpc.interval_s,
        solve_time_s=0.0,
        iterations=None,
        solver="none",
    )
    return params, nmpc, plan, cn.check_plan(plan, params)


def test_checker_confirms_a_feasible_rk4_rollout(rollout_plan):
    _, _, _, report = rollout_plan
    print({name: f"{value:.3g}" for name, value in report.items()})
    # Inputs at 0.05 N tilted 0.5 rad inside the pi/4 pyramid: strictly inside.
    assert report["gimbal_excess_N"] < 0.0
    assert report["magnitude_excess_N"] == pytest.approx(0.05 - 20.0, abs=1e-12)
    assert report["los_excess_m"] <= 1e-12 and report["min_slack_m"] >= 0.0
    # RK4 with 2 steps of 30 s against DOP853 (rtol 1e-11): the transcription's own error on a
    # slow trajectory (rates ~1e-2 rad/s, rotation ~0.3 rad per step: RK4's local error ~1e-5).
    assert report["defect_R_TC"] < 1e-4
    assert report["defect_p_PtPc_T_m"] < 1e-2
    assert report["rollout_p_PtPc_T_m"] < 1e-1
    assert report["so3_error"] < 1e-3  # measured 1.6e-4 (RK4 drift off SO(3) over 16 steps)
    # The target reference (RK4 + projection) against DOP853 on its 6.7e6 m orbit.
    assert report["rollout_target_p_m"] < 1.0


def test_checker_reports_violations(rollout_plan):
    params, _, plan, _ = rollout_plan
    bad = plan.u.copy()
    bad[3, 6:9] *= 25.0 / np.linalg.norm(bad[3, 6:9])  # thruster 2 at 25 N on interval 3
    bad[5, 0:3] = -plan.u[5, 0:3]  # thruster 0 pushing against its nominal direction
    moved = plan.x.copy()
    moved[4, cr.P_PTPC_T_SLICE] += [0.0, 0.3, 0.0]
    report = cn.check_plan(cn.NmpcResult(**{**plan.__dict__, "u": bad, "x": moved}), params)
    assert report["magnitude_excess_N"] == pytest.approx(5.0, abs=1e-9)
    assert report["gimbal_excess_N"] > 0.0
    assert report["defect_p_PtPc_T_m"] > 0.29


def test_shifted_warm_start_shifts_one_interval_and_repeats_the_last_input(rollout_plan):
    _, nmpc, plan, _ = rollout_plan
    guess = nmpc.shifted_warm_start(plan)
    np.testing.assert_array_equal(guess.u[:-1], plan.u[1:])
    np.testing.assert_array_equal(guess.u[-1], plan.u[-1])
    np.testing.assert_array_equal(guess.x[:-1], plan.x[1:])
    x_end, q = cn.rk4_interval(
        plan.x[-1], plan.u[-1], nmpc.interval_s, 2, nmpc.params, nmpc.weights
    )
    np.testing.assert_array_equal(guess.x[-1], x_end)
    assert guess.stage_costs[-1] == q


# ------------------------------------------------------------------ (c) failure is a status


def test_iteration_limit_is_a_status_not_an_exception():
    params = cr.CoupledRelativeParams()
    nmpc = cn.CoupledNmpc(params, settings=cn.CoupledNmpcSettings(max_iterations=1))
    result = nmpc.solve(_sec_iv_start(params))
    assert result.status is cn.NmpcStatus.MAX_ITERATIONS
    assert not result.solved
    assert result.solver_message  # IPOPT's own word
    assert result.iterations == 1
    assert result.u.shape == (8, cr.INPUT_SIZE) and result.x.shape == (9, cr.STATE_SIZE)
    np.testing.assert_allclose(result.x[0], _sec_iv_start(params), atol=1e-9)


def test_bad_settings_are_rejected_by_name():
    with pytest.raises(ValueError, match="rk4_substeps"):
        cn.CoupledNmpcSettings(rk4_substeps=1).validate()
    with pytest.raises(ValueError, match="solver"):
        cn.CoupledNmpcSettings(solver="osqp").validate()
