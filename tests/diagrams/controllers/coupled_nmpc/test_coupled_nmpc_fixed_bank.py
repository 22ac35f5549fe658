"""Paper 001's NMPC on a fixed thruster bank (the shoot-out's rcs_cube_12, issue 22): one thrust
per thruster (eqs. 11-12 with the gimbal angles fixed), the attitude goal facing the port
(`attitude_goal: facing`, a turned chaser frame C'), the weights from the config. Paper 001's
own scenarios are unchanged (its tests pass as they were; the config's defaults are Sec. IV's
weights bit for bit, tested here)."""

import dataclasses

import numpy as np
import pytest

from rpod.diagrams.controllers.coupled_nmpc import problem
from rpod.diagrams.controllers.coupled_nmpc.config import CostWeights, CoupledNmpc
from rpod.diagrams.mission import Capture
from rpod.diagrams.scenario import ScenarioError, make_thruster_layout, validate_scenario
from rpod.diagrams.simulate import simulate
from rpod.models import coupled_relative as cr
from rpod.models.gimbal import force_to_wrench_matrix
from rpod.models.thrusters import rcs_cube_12
from rpod.planners import coupled_nmpc as cn
from rpod.planners.coupled_sqp import SqpSettings
from rpod.scenarios.loader import load_scenario


def _fixed_params(**fields):
    return cr.CoupledRelativeParams(layout=rcs_cube_12(2.4, 75.0, 220.0), **fields)


def test_a_fixed_bank_plans_one_thrust_per_thruster_along_its_nozzle():
    params = _fixed_params()
    assert params.input_size == 12
    u = np.linspace(0.0, 75.0, 12)
    forces = cr.thruster_forces_C(u, params)
    np.testing.assert_allclose(forces, u[:, None] * params.layout.directions_C)
    # The input-to-wrench map is eqs. 11-12 on those force vectors.
    expected = force_to_wrench_matrix(params.layout) @ forces.reshape(-1)
    np.testing.assert_allclose(cr.chaser_wrench(params, u), expected, atol=1e-12)
    np.testing.assert_allclose(cr._force_to_wrench_matrix(params) @ u, expected, atol=1e-12)


def test_the_sqp_plans_a_fixed_bank_inside_its_box_and_the_checker_agrees():
    params = _fixed_params(
        chaser_mass_kg=1500.0,
        J_c=np.diag([4300.0, 1300.0, 4100.0]),
        p_TPt_T=np.array([0.0, 0.0, 2.7]),
        p_CPc_C=np.array([0.0, 0.0, 2.7]),
    )
    settings = cn.CoupledNmpcSettings(
        horizon_s=20.0, intervals=8, solver="sqp", max_iterations=60,
        max_relative_rate_rad_s=0.3,
    )  # fmt: skip
    weights = problem.coupled_weights(
        CoupledNmpc(weights=CostWeights(position=1.0, force=1e-3)), params.input_size
    )
    nmpc = cn.CoupledNmpc(params, weights, settings)
    x0 = cr.sec_iv_initial_state(params)
    x0[cr.P_PTPC_T_SLICE] = [1.0, -2.0, 6.0]  # the capture point 6 m out, the chaser aligned
    x0[cr.V_PTPC_T_SLICE] = 0.0
    x0[cr.W_TC_T_SLICE] = 0.0
    x0[cr.R_TC_SLICE] = np.eye(3).reshape(9)
    result = nmpc.solve(x0)
    assert result.usable, (result.status, result.solver_message)
    assert result.u.shape == (8, 12)
    report = cn.check_plan(result, params)
    assert report["gimbal_excess_N"] < 1e-3  # no thrust below zero
    assert report["magnitude_excess_N"] < 1e-3  # nor above f_max
    assert report["defect_p_PtPc_T_m"] < 1e-2
    # It closes in: the plan's last node is nearer the rock than the start.
    assert np.linalg.norm(result.x[-1, cr.P_PTPC_T_SLICE]) < 0.5 * np.linalg.norm([1, -2, 6])


def test_gimbaled_only_solvers_are_refused_on_a_fixed_bank():
    with pytest.raises(ValueError, match="solver: a fixed thruster bank is planned by"):
        cn.CoupledNmpc(_fixed_params(), settings=cn.CoupledNmpcSettings(solver="ipopt"))


@pytest.mark.parametrize(
    "capture_axis, port", [([0.0, 0.0, 2.7], [0.0, 0.0, 2.7]), ([0.3, -1.0, 0.2], [1.0, 2.0, 3.0])]
)
def test_the_facing_attitude_turns_the_capture_axis_against_the_port_axis(capture_axis, port):
    R = problem.facing_attitude_R_TC(port, capture_axis)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    c, a = np.asarray(capture_axis), np.asarray(port)
    np.testing.assert_allclose(R @ (c / np.linalg.norm(c)), -a / np.linalg.norm(a), atol=1e-12)


def _shootout_nmpc():
    """The shoot-out's !CoupledNmpc case on paper 000's task (scenarios/bundled/campaigns/
    shootout.yaml)."""
    return CoupledNmpc(
        control_period_s=2.5,
        integral_step_s=0.5,
        attitude_goal="facing",
        weights=CostWeights(position=1.0, force=1e-3, terminal_position=30.0, terminal_velocity=67.0),
        nmpc=cn.CoupledNmpcSettings(
            horizon_s=30.0, intervals=12, solver="rti", max_iterations=20,
            max_relative_rate_rad_s=0.3,
            sqp=SqpSettings(rti_osqp_eps=1e-3, cold_start_max_iterations=40, osqp_max_iter=4000),
        ),
    )  # fmt: skip


def test_the_planning_frame_carries_the_chaser_into_C_prime():
    _, scenario = load_scenario("soft_capture")
    scenario.controller = _shootout_nmpc()
    R_CCp = problem.planning_frame_R_CCp(scenario)
    params = problem.coupled_params(scenario)
    layout = make_thruster_layout(scenario)
    # The same thrusts give the same wrench, expressed in C'.
    u = np.arange(12.0)
    wrench_C = force_to_wrench_matrix(layout) @ (u[:, None] * layout.directions_C).reshape(-1)
    wrench_Cp = cr.chaser_wrench(params, u)
    np.testing.assert_allclose(wrench_Cp[:3], R_CCp.T @ wrench_C[:3], atol=1e-10)
    np.testing.assert_allclose(wrench_Cp[3:], R_CCp.T @ wrench_C[3:], atol=1e-10)
    # The capture point, in C', is where R_TC' = I puts it against the port.
    np.testing.assert_allclose(params.p_CPc_C, [0.0, 0.0, -2.7], atol=1e-12)


@pytest.mark.parametrize(
    "change, field",
    [
        ({"attitude_goal": "sideways"}, "controller.attitude_goal"),
        ({"weights": CostWeights(force=-1.0)}, "controller.weights.force"),
    ],
)
def test_bad_fixed_bank_settings_are_named(change, field):
    _, scenario = load_scenario("soft_capture")
    scenario.controller = dataclasses.replace(_shootout_nmpc(), **change)
    with pytest.raises(ScenarioError, match=field.replace(".", r"\.")):
        validate_scenario(scenario)


def test_facing_is_refused_on_paper_001_s_gimbaled_bank():
    _, scenario = load_scenario("asteroid_grasp")
    scenario.controller = dataclasses.replace(scenario.controller, attitude_goal="facing")
    with pytest.raises(ScenarioError, match=r"controller\.attitude_goal"):
        validate_scenario(scenario)


def test_from_behind_the_target_the_fixed_bank_nmpc_captures_without_contact():
    """Shoot-out start 76 (0.88 deg/s, 21 m, the chaser behind the target: where paper 004's
    guidance stalled without its entry regime), flown through the allocator-free path: the
    NMPC's levels through the PWM to the rcs_cube_12 bank."""
    _, scenario = load_scenario("soft_capture")
    scenario.controller = _shootout_nmpc()
    scenario.mission = Capture()
    scenario.target.rpy_LT_deg = []
    scenario.target.q_LT = [0.251676, -0.805143, -0.0126618, 0.536883]
    scenario.target.w_IT_T_deg_s = [-0.816289, 0.335531, -0.0543506]
    scenario.chaser.p_LC_L = [18.620993, -9.754578, 1.752391]
    scenario.chaser.v_LC_L = [-0.0045238, -0.0345429, -0.0219676]
    scenario.chaser.rpy_LC_deg = [-100.184437, -61.976551, 71.363498]
    scenario.duration_s = 150.0
    summary = simulate(scenario).summary
    mission = summary["mission"]
    assert mission["success"], mission["outcome"]
    assert mission["capture"]["position_error_m"] <= 0.35
    assert not summary["contact"]["occurred"] and summary["min_separation_m"] > 1.0
    assert summary["nmpc_solves"] > 10 and summary["coupled_max_magnitude_excess_N"] <= 1e-9


def test_the_config_s_default_weights_are_sec_iv_s_bit_for_bit():
    config = CoupledNmpc()
    built = problem.coupled_weights(config, cr.INPUT_SIZE)
    paper = cr.CoupledNmpcWeights(Q_xi=config.integral_weight * np.eye(3))
    for name in ("Q_R", "D", "Q_w", "Q_p", "Q_xi", "W_tau", "W_f", "P"):
        assert np.array_equal(np.asarray(getattr(built, name)), np.asarray(getattr(paper, name)))


def test_a_gimbaled_layout_other_than_paper_001_s_eight_is_refused():
    from rpod.models.thrusters import gimbaled_cuboid_8

    eight = gimbaled_cuboid_8(max_thrust_N=20.0)
    six = dataclasses.replace(eight, thrusters=eight.thrusters[:6])
    with pytest.raises(ValueError, match="gimbaled layout must hold paper 001's 8"):
        cr.CoupledRelativeParams(layout=six)
