"""The diagram builder: structure, initial conditions and an audit of the thrust chain.

Truths: the scenario's attitudes are given in LVLH and must come out of the truth as
R_IT = R_IL R_LT; a coasting chaser in free space moves on a straight line; the propellant the
truth integrated must equal the impulse the PWM actually delivered (ON slots x thrust / (Isp g0)),
read from the PWM's own per-period record, independent of the integrator.
"""

import dataclasses

import numpy as np
import pytest
from pydrake.math import RotationMatrix

from rpod.diagrams.builder import build_diagram
from rpod.diagrams.scenario import (
    ChaserConfig,
    Scenario,
    ScenarioError,
    TargetConfig,
    ThrustersConfig,
    validate_scenario,
)
from rpod.diagrams.simulate import simulate
from rpod.models.frames import rotation_from_rpy_deg, rotation_from_wxyz
from rpod.models.orbit import OrbitConfig
from rpod.models.thrusters import STANDARD_GRAVITY_M_S2


def test_controlled_diagram_has_every_named_system():
    diagram, handles = build_diagram(Scenario(duration_s=1.0))
    names = {system.get_name() for system in diagram.GetSystems()}
    assert {
        "truth",  # both orbits, both attitudes, the mass and the thrusters (rpod.systems.truth)
        "pwm",
        "wrench_allocator",
        "hold_point_controller",
        "safety_monitor",
    } <= names
    assert handles.layout.count == 12


def test_initial_attitudes_are_given_relative_to_lvlh():
    scenario = Scenario(
        duration_s=1.0,
        target=TargetConfig(rpy_LT_deg=[10.0, -20.0, 90.0]),
        chaser=ChaserConfig(rpy_LC_deg=[0.0, 45.0, 0.0]),
        thrusters=ThrustersConfig(enabled=False),
        controller=None,
    )
    log = simulate(scenario).log
    R_IL = rotation_from_wxyz(log["q_IL"][0])
    np.testing.assert_allclose(
        R_IL.T @ rotation_from_wxyz(log["q_IT"][0]),
        rotation_from_rpy_deg([10.0, -20.0, 90.0]),
        atol=1e-12,
    )
    np.testing.assert_allclose(
        R_IL.T @ rotation_from_wxyz(log["q_IC"][0]),
        rotation_from_rpy_deg([0.0, 45.0, 0.0]),
        atol=1e-12,
    )


def test_target_quaternion_gives_the_attitude():
    """q_LT alone sets R_LT. (It used to win silently over a given rpy_LT_deg; giving both is now
    a field error, tests/diagrams/test_scenario_validation.py.)"""
    half = np.radians(30.0) / 2
    scenario = Scenario(
        duration_s=1.0,
        target=TargetConfig(q_LT=[np.cos(half), 0.0, 0.0, np.sin(half)]),
        thrusters=ThrustersConfig(enabled=False),
        controller=None,
    )
    log = simulate(scenario).log
    R_LT = rotation_from_wxyz(log["q_IL"][0]).T @ rotation_from_wxyz(log["q_IT"][0])
    np.testing.assert_allclose(R_LT, rotation_from_rpy_deg([0, 0, 30.0]), atol=1e-12)


def test_free_space_coast_is_a_straight_line():
    p0, v0 = np.array([1.0, -20.0, 3.0]), np.array([0.01, 0.05, -0.02])
    scenario = Scenario(
        duration_s=100.0,
        orbit=OrbitConfig(gravity="free_space"),
        chaser=ChaserConfig(p_LC_L=list(p0), v_LC_L=list(v0)),
        thrusters=ThrustersConfig(enabled=False),
        controller=None,
    )
    log = simulate(scenario).log
    expected = p0 + log["t"][:, None] * v0
    np.testing.assert_allclose(log["p_LC_L"], expected, atol=1e-9)  # exact up to round-off


def test_propellant_equals_the_impulse_the_pwm_delivered():
    base = Scenario()
    thrusters = base.thrusters
    slot_s = base.controller.control_period_s / thrusters.subdivisions
    # Log at the slot period: the logger's and the PWM's event times are then computed alike,
    # so every row is published before that instant's PWM update and row j holds slot j - 1.
    # (With a log period of, say, 0.1 s, 0.1 k and 0.01 (10 k) differ in the last bit, and a
    # row may land on either side of a period's update.)
    scenario = dataclasses.replace(base, duration_s=20.0, log_period_s=slot_s)
    result = simulate(scenario)
    log = result.log
    on_slots = log["thruster_on"][1:]
    np.testing.assert_array_equal(on_slots, np.round(on_slots))  # on/off, nothing between
    on_time_s = on_slots.sum() * slot_s
    expected_kg = on_time_s * thrusters.max_thrust_N / (thrusters.isp_s * STANDARD_GRAVITY_M_S2)
    assert expected_kg > 0.01  # the chaser did fire
    # The mass flow is constant over each slot and RK3 steps end at every slot: exact.
    assert log["propellant_kg"][-1] == pytest.approx(expected_kg, rel=1e-9)
    assert result.summary["propellant_kg"] == pytest.approx(expected_kg, rel=1e-9)


def test_point_at_target_starts_with_the_capture_axis_on_the_line_of_sight():
    """chaser.point_at_target: R_LC c_hat = -p_hat at t = 0 (to 1e-12), the least rotation."""
    scenario = Scenario(
        duration_s=1.0,
        chaser=ChaserConfig(
            p_LC_L=[12.0, -30.0, 5.0], capture_point_C=[0.3, 0.0, 0.75], point_at_target=True
        ),
        thrusters=ThrustersConfig(enabled=False),
        controller=None,
    )
    log = simulate(scenario).log
    R_LC = rotation_from_wxyz(log["q_IL"][0]).T @ rotation_from_wxyz(log["q_IC"][0])
    c_hat = np.array([0.3, 0.0, 0.75]) / np.linalg.norm([0.3, 0.0, 0.75])
    p_hat = np.array([12.0, -30.0, 5.0]) / np.linalg.norm([12.0, -30.0, 5.0])
    np.testing.assert_allclose(R_LC @ c_hat, -p_hat, atol=1e-12)
    # The least rotation: its axis is normal to both directions.
    angle_axis = RotationMatrix(R_LC).ToAngleAxis()
    assert abs(angle_axis.axis() @ c_hat) < 1e-9 and abs(angle_axis.axis() @ p_hat) < 1e-9


def test_point_at_target_and_a_given_attitude_is_a_field_error():
    scenario = Scenario(chaser=ChaserConfig(rpy_LC_deg=[0.0, 10.0, 0.0], point_at_target=True))
    with pytest.raises(ScenarioError, match="given twice") as error:
        validate_scenario(scenario)
    assert error.value.field == "chaser.point_at_target"


@pytest.mark.parametrize("scheme", ["round", "schmitt", "delta_sigma"])
def test_the_modulation_scheme_reaches_the_pwm(scheme):
    scenario = Scenario()
    scenario.thrusters.modulation = scheme
    scenario.thrusters.schmitt_hysteresis = 0.3
    diagram, _ = build_diagram(scenario)
    pwm = diagram.GetSubsystemByName("pwm")
    assert pwm.scheme == scheme
