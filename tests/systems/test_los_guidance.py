"""Paper 004's guidance system: the body-frame command against finite differences of the
kinematics, the regimes on hand-worked states, and a forced infeasible QP taking the fallback
(the previous plan's next input, then braking)."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from rpod.models.cw import cw_acceleration
from rpod.models.frames import quaternion_wxyz, skew
from rpod.models.orbit import OrbitConfig, initial_orbit_state, lvlh_of
from rpod.planners.los_corridor_mpc import LosMpcSettings, MpcStatus
from rpod.systems.los_guidance import (
    MPC_STATUS_CODES,
    BodyFrameView,
    Fallback,
    LosGuidance,
    LosGuidanceConfig,
    Regime,
    regime,
)
from rpod.systems.sensed import sensed_vector

OMEGA = np.radians(2.0)
INERTIA = np.diag([1000.0, 1000.0, 1200.0])


def _sensed(p_T, v_T, yaw_deg=0.0):
    """The sensed bundle of a target on a 500 km orbit spinning at 2 deg/s about z_T, the
    chaser at p_T with velocity v_T seen in T (both in T)."""
    p_I, v_I = initial_orbit_state(OrbitConfig(altitude_m=500e3, inclination_deg=51.6))
    R_IL, w_IL_L = lvlh_of(p_I, v_I, "two_body_j2")
    R_LT = Rotation.from_euler("z", yaw_deg, degrees=True).as_matrix()
    w_IT_T = np.array([0.0, 0.0, OMEGA])
    w_LT_T = w_IT_T - R_LT.T @ w_IL_L
    p_L = R_LT @ np.asarray(p_T, float)
    v_L = R_LT @ (np.asarray(v_T, float) + np.cross(w_LT_T, p_T))
    return sensed_vector(
        np.r_[p_L, v_L],
        quaternion_wxyz(R_IL),
        w_IL_L,
        np.r_[quaternion_wxyz(R_IL @ R_LT), w_IT_T],
        np.r_[1.0, 0, 0, 0, 0, 0, 0],
        np.r_[p_I, v_I],
    )


def test_the_body_frame_command_gives_the_asked_acceleration_seen_in_T():
    """u_L = command_L(a_T) flown on CW (eq. 4): p_T(t) = R_TL(t) p_L(t) has p_T'' = a_T
    (second central difference; the frame turns at a constant w_LT_T)."""
    from rpod.systems.sensed import Sensed

    view = BodyFrameView.from_sensed(
        Sensed.from_vector(_sensed([8.0, 60.0, 3.0], [0.2, -0.5, 0.1], 40.0))
    )
    a_T = np.array([0.01, -0.03, 0.02])
    a_L = cw_acceleration(view.n, view.p_L, view.v_L) + view.command_L(a_T)
    h = 1e-3

    def p_T(t):
        p_L = view.p_L + view.v_L * t + 0.5 * a_L * t * t
        R_LT = view.R_LT @ expm(skew(view.w_LT_T) * t)
        return R_LT.T @ p_L

    second = (p_T(h) - 2.0 * p_T(0.0) + p_T(-h)) / h**2
    np.testing.assert_allclose(second, a_T, atol=2e-6)
    # And the velocity seen in T is eq. 8's: the first central difference.
    np.testing.assert_allclose((p_T(h) - p_T(-h)) / (2 * h), view.v_T, atol=1e-6)


def test_regimes_on_hand_worked_states():
    config = LosGuidanceConfig()
    H = np.array([0.0, 10.0, 0.0])
    r_sync = 164.1
    from rpod.systems.sensed import Sensed

    def mode(p_T, v_T, holding=False):
        view = BodyFrameView.from_sensed(Sensed.from_vector(_sensed(p_T, v_T)))
        return regime(view, H, r_sync, holding, config)

    assert mode([0, 250, 0], [0, 0, 0]) is Regime.FAR  # 250 m > r_sync
    assert mode([0, 150, 0], [0, 0, 0]) is Regime.CLOSE
    assert mode([0.3, 10.5, 0], [0.01, 0, 0]) is Regime.HOLD  # within 1 m and 0.05 m/s
    assert mode([0.3, 10.5, 0], [0.2, 0, 0]) is Regime.CLOSE  # too fast to hold
    assert mode([0, 11.8, 0], [0.2, 0, 0], holding=True) is Regime.HOLD  # hysteresis: < 2 m
    assert mode([0, 12.5, 0], [0.0, 0, 0], holding=True) is Regime.CLOSE


def _guidance(horizon=5, corridor_penalty=0.0):
    """The paper's hard 11d (no margin, no funnel) and the whole last plan as the fallback;
    no best-effort QP unless a corridor_penalty is given."""
    settings = LosMpcSettings(
        horizon=horizon, margin_m=0.0, recovery_steps=0, corridor_penalty=corridor_penalty
    )
    config = LosGuidanceConfig(mpc=settings, fallback_plan_steps=horizon)
    system = LosGuidance(config, INERTIA, "two_body_j2")
    context = system.CreateDefaultContext()
    return system, context, Simulator(system, context)


def _status(system, context):
    return system.GetOutputPort("guidance_status").Eval(context)


def test_a_forced_infeasible_qp_takes_the_previous_plan_then_brakes():
    system, context, simulator = _guidance(horizon=5)
    port = system.get_input_port(0)
    port.FixValue(context, _sensed([3.0, 40.0, 0.0], [0.0, -0.2, 0.0]))
    simulator.AdvanceTo(0.5)  # the update at t = 0: solved, a plan of 5 inputs kept
    status = _status(system, context)
    assert status[1] == MPC_STATUS_CODES[MpcStatus.SOLVED] and status[2] == Fallback.NONE
    plan = context.get_abstract_state(0).get_value().copy()
    assert plan.shape == (5, 3)

    # Behind the target (y_T < 0): x_0 violates 11d, the QP is infeasible at every step.
    port.FixValue(context, _sensed([0.0, -5.0, 0.0], [0.0, 0.1, 0.0]))
    for k in range(1, 5):
        simulator.AdvanceTo(k + 0.5)
        status = _status(system, context)
        assert status[1] == MPC_STATUS_CODES[MpcStatus.PRIMAL_INFEASIBLE]
        assert status[2] == Fallback.PREVIOUS_PLAN
        np.testing.assert_array_equal(
            system.GetOutputPort("acceleration_command_L").Eval(context), plan[k]
        )
    simulator.AdvanceTo(5.5)  # the plan is used up: brake, inside the box
    status = _status(system, context)
    assert status[2] == Fallback.BRAKE
    command = system.GetOutputPort("acceleration_command_L").Eval(context)
    assert np.all(np.abs(command) <= 0.1) and np.linalg.norm(command) > 0


def test_a_failed_qp_flies_the_best_effort_input_before_any_fallback():
    """With the best-effort QP (rpod's default), the step whose hard QP is infeasible flies the
    soft QP's u_0, inside the box, and keeps its plan: neither the previous plan nor the brake."""
    system, context, simulator = _guidance(horizon=5, corridor_penalty=1e5)
    port = system.get_input_port(0)
    port.FixValue(context, _sensed([3.0, 40.0, 0.0], [0.0, -0.2, 0.0]))
    simulator.AdvanceTo(0.5)
    assert _status(system, context)[2] == Fallback.NONE
    port.FixValue(context, _sensed([0.0, -5.0, 0.0], [0.0, 0.1, 0.0]))  # behind the target
    for k in range(1, 4):
        simulator.AdvanceTo(k + 0.5)
        status = _status(system, context)
        assert status[1] == MPC_STATUS_CODES[MpcStatus.PRIMAL_INFEASIBLE]
        assert status[2] == Fallback.BEST_EFFORT
        command = system.GetOutputPort("acceleration_command_L").Eval(context)
        plan = context.get_abstract_state(0).get_value()
        np.testing.assert_array_equal(command, plan[0])
        assert np.all(np.abs(command) <= 0.1 + 1e-9)


def test_without_the_filter_the_regime_command_is_flown_clipped():
    config = LosGuidanceConfig(filter=False)
    system = LosGuidance(config, INERTIA, "two_body_j2")
    context = system.CreateDefaultContext()
    system.get_input_port(0).FixValue(context, _sensed([20.0, 120.0, 0.0], [0.0, 0.0, 0.0]))
    Simulator(system, context).AdvanceTo(0.5)
    command = system.GetOutputPort("acceleration_command_L").Eval(context)
    nominal = system.GetOutputPort("nominal_command_L").Eval(context)
    np.testing.assert_array_equal(command, np.clip(nominal, -0.1, 0.1))
    assert _status(system, context)[1] == -1  # no QP was solved


def test_face_distance_is_the_signed_distance_to_each_plane():
    system, context, _ = _guidance()
    system.get_input_port(0).FixValue(context, _sensed([0.0, 20.0, 0.0], [0, 0, 0], 70.0))
    distance = system.GetOutputPort("face_distance_m").Eval(context)
    # On the axis 20 m up: every face is 20 sin(30 deg) = 10 m away, the floor 19 m.
    np.testing.assert_allclose(distance[:8], 10.0, atol=1e-9)
    assert distance[8] == pytest.approx(19.0, abs=1e-9)


def test_the_last_resort_brakes_when_the_box_allows_and_else_flies_the_regime_command():
    from rpod.systems.sensed import Sensed

    system, _, _ = _guidance()
    slow = BodyFrameView.from_sensed(Sensed.from_vector(_sensed([0.0, -5.0, 0.0], [0.0, 0.05, 0])))
    command, fallback = system._last_resort(slow, Regime.CLOSE, np.array([0.3, 0.0, 0.0]))
    assert fallback is Fallback.BRAKE and np.all(np.abs(command) <= 0.1)
    np.testing.assert_allclose(command, slow.command_L(-slow.v_T / 1.0))  # zero v_T in 1 s
    # At 120 m the co-rotation alone needs omega^2 r = 0.15 m/s^2 > a_max: no brake.
    far = BodyFrameView.from_sensed(Sensed.from_vector(_sensed([0.0, 120.0, 0.0], [0.5, 0, 0])))
    command, fallback = system._last_resort(far, Regime.CLOSE, np.array([0.3, -0.05, 0.0]))
    assert fallback is Fallback.NOMINAL
    np.testing.assert_array_equal(command, [0.1, -0.05, 0.0])


def _entry_guidance(**fields):
    config = LosGuidanceConfig(entry=True, **fields)
    return LosGuidance(config, INERTIA, "two_body_j2", keep_out_m=8.46)


def _view(p_T, v_T=(0.0, 0.0, 0.0)):
    from rpod.systems.sensed import Sensed

    return BodyFrameView.from_sensed(Sensed.from_vector(_sensed(p_T, v_T)))


def _off_axis_deg(p):
    return np.degrees(np.arccos(p[1] / np.linalg.norm(p)))


@pytest.mark.parametrize("range_m", [9.0, 10.46, 15.0, 40.0])
@pytest.mark.parametrize("off_axis_deg", [35.0, 90.0, 150.0, 179.0, 180.0])
def test_the_entry_reference_turns_toward_the_axis_with_its_chord_clear_of_the_keep_out(
    range_m, off_axis_deg
):
    system = _entry_guidance()
    angle = np.radians(off_axis_deg)
    p = range_m * np.array([np.sin(angle) * 0.6, np.cos(angle), np.sin(angle) * 0.8])
    reference = system._entry_reference(_view(p), speed_limit=1.0)
    assert np.linalg.norm(reference) >= 8.46 + 2.0 - 1e-9  # never inside the entry sphere
    assert _off_axis_deg(reference) < _off_axis_deg(p)  # nearer the corridor's axis
    # Every point of the chord from the chaser to the reference is beyond the keep-out sphere.
    chord = p + np.linspace(0.0, 1.0, 401)[:, None] * (reference - p)
    assert np.min(np.linalg.norm(chord, axis=1)) >= 8.46 - 1e-9


def test_the_entry_regime_flies_its_pd_unfiltered_and_hands_over_inside_the_gate():
    system = _entry_guidance()
    context = system.CreateDefaultContext()
    system.get_input_port(0).FixValue(context, _sensed([0.0, -20.0, 3.0], [0.0, 0.0, 0.0]))
    Simulator(system, context).AdvanceTo(0.5)
    status = _status(system, context)
    assert status[0] == Regime.ENTRY and status[1] == -1  # no QP solved
    command = system.GetOutputPort("acceleration_command_L").Eval(context)
    nominal = system.GetOutputPort("nominal_command_L").Eval(context)
    np.testing.assert_array_equal(command, np.clip(nominal, -0.1, 0.1))
    # Entered beyond the corridor's 30 deg, left only within the 15 deg gate.
    at_20_deg = _view(20.0 * np.array([np.sin(np.radians(20)), np.cos(np.radians(20)), 0.0]))
    assert system._entering(at_20_deg, entering=True)
    assert not system._entering(at_20_deg, entering=False)
    at_10_deg = _view(20.0 * np.array([np.sin(np.radians(10)), np.cos(np.radians(10)), 0.0]))
    assert not system._entering(at_10_deg, entering=True)


def test_an_entry_gate_outside_the_corridor_is_refused():
    from rpod.models.config import ConfigError

    with pytest.raises(ConfigError, match="entry_gate_deg"):
        LosGuidanceConfig(entry=True, entry_gate_deg=30.0).validate()
    LosGuidanceConfig(entry=False, entry_gate_deg=30.0).validate()  # off: not checked
