"""The soft-capture plug-in: its part of the scenario and of the run summary.

Validation: bad numbers are config errors that name the field; the planner's problem data are
derived from the scenario, never written twice; a tumble above the method's limit is not a
config error (the planner reports it at run time).
Capture criterion (`capture_outcome`): synthetic logs with a known answer -- the chaser turned by
pi about y (capture axis toward the target) on the target's +z axis, so the capture points'
distance is exactly |p_z - 5.4| m.
"""

import dataclasses

import numpy as np
import pytest

from rpod.diagrams.builder import build_diagram
from rpod.diagrams.controllers.soft_capture import capture_outcome, planner_config
from rpod.diagrams.scenario import ScenarioError, validate_scenario
from rpod.models.gravity import R_EARTH_M
from rpod.scenarios.loader import ScenarioFileError, load_scenario, parse_scenario

Q_IDENTITY = [1.0, 0.0, 0.0, 0.0]
Q_FLIP_Y = [0.0, 0.0, 1.0, 0.0]  # pi about y: the chaser's +z points along -z_L


def _scenario():
    return load_scenario("soft_capture")[1]


def _with(scenario, **changes):
    """A copy of the scenario with dotted fields changed, e.g. {'chaser.shape': 'sphere'}."""
    scenario = dataclasses.replace(scenario)
    for dotted, value in changes.items():
        *parents, leaf = dotted.split("__")
        node = scenario
        for name in parents:
            child = dataclasses.replace(getattr(node, name))
            setattr(node, name, child)
            node = child
        setattr(node, leaf, value)
    return scenario


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"controller__planner__max_speed_m_s": -1.0}, "controller.planner.max_speed_m_s"),
        ({"controller__replan_period_s": 2.5}, "controller.replan_period_s"),
        ({"controller__collision_margin": -0.1}, "controller.collision_margin"),
        ({"chaser__shape": "sphere"}, "chaser.shape"),
        ({"target__shape": "soft_capture_chaser"}, "target.shape"),
        ({"target__docking_axis_T": [1.0, 0.0, 0.0]}, "target.docking_axis_T"),
        ({"orbit__gravity": "free_space"}, "orbit.gravity"),
        ({"thrusters__enabled": False}, "thrusters.enabled"),
    ],
)  # fmt: skip
def test_bad_soft_capture_settings_name_their_field(changes, field):
    with pytest.raises(ScenarioError) as error:
        validate_scenario(_with(_scenario(), **changes))
    assert error.value.field == field


def test_the_planner_problem_data_come_from_the_scenario():
    """a, m, D_c, D_t and theta_dock are the orbit's, chaser's and target's: no copies."""
    scenario = _with(
        _scenario(),
        orbit__altitude_m=800e3,
        chaser__mass_kg=900.0,
        chaser__capture_point_C=[0.0, 0.0, 2.0],
        target__docking_port_T=[0.0, 0.0, 1.9],
        target__corridor_half_angle_deg=25.0,
    )
    validate_scenario(scenario)
    config = planner_config(scenario)
    assert config.semi_major_axis_m == R_EARTH_M + 800e3
    assert config.chaser_mass_kg == 900.0 and config.docking_half_angle_deg == 25.0
    assert config.p_CDc_C == [0.0, 0.0, 2.0] and config.p_TDt_T == [0.0, 0.0, 1.9]
    assert config.max_speed_m_s == scenario.controller.planner.max_speed_m_s  # the settings


def test_a_tumble_above_the_limit_is_not_a_config_error():
    validate_scenario(_with(_scenario(), target__w_IT_T_deg_s=[15.0, 0.0, 0.0]))


def test_the_loader_names_file_and_field_of_a_bad_soft_capture_value():
    text = "controller: !SoftCapture\n  planner:\n    min_knots: ten\n"
    with pytest.raises(ScenarioFileError, match=r"^my.yaml: controller.planner.min_knots"):
        parse_scenario(text, "my.yaml")


def test_the_soft_capture_diagram_uses_the_true_polytopes():
    diagram, handles = build_diagram(_scenario())
    names = {system.get_name() for system in diagram.GetSystems()}
    assert {"soft_capture_controller", "wrench_allocator", "pwm", "truth"} <= names
    assert len(handles.monitor._chaser_shape.b) == 8 and len(handles.monitor._target_shape.b) == 7
    pwm = diagram.GetSubsystemByName("pwm")
    assert pwm.control_period_s == pytest.approx(0.1)


def _log(p_z, speed, separation):
    n = len(p_z)
    return {
        "t": np.arange(n, dtype=float),
        "p_LC_L": np.column_stack([np.zeros(n), np.zeros(n), p_z]),
        "q_IL": np.tile(Q_IDENTITY, (n, 1)),
        "q_IT": np.tile(Q_IDENTITY, (n, 1)),
        "q_IC": np.tile(Q_FLIP_Y, (n, 1)),
        "capture_speed_m_s": np.asarray(speed, float),
        "separation_m": np.asarray(separation, float),
    }


def test_capture_succeeds_at_the_first_sample_within_both_tolerances():
    log = _log([9.0, 6.0, 5.6, 5.5, 5.4], [0.5, 0.2, 0.05, 0.02, 0.0], [3, 1, 0.5, 0.5, 0.5])
    outcome = capture_outcome(log, _scenario())
    assert outcome["success"], outcome
    assert outcome["time_s"] == 3.0
    assert outcome["position_error_m"] == pytest.approx(0.1, abs=1e-12)
    assert outcome["speed_error_m_s"] == 0.02


def test_contact_before_capture_fails_with_its_time():
    log = _log([9.0, 6.0, 5.6, 5.5, 5.4], [0.5, 0.2, 0.05, 0.02, 0.0], [3, 0.0, 0.5, 0.5, 0.5])
    outcome = capture_outcome(log, _scenario())
    assert not outcome["success"] and outcome["reason"].startswith("contact")
    assert outcome["time_s"] == 1.0


def test_contact_after_capture_does_not_undo_it_but_is_reported():
    log = _log([9.0, 5.5, 5.4], [0.5, 0.02, 0.0], [3, 0.5, 0.0])
    outcome = capture_outcome(log, _scenario())
    assert outcome["success"] and outcome["contact_after_s"] == 2.0
    clean = capture_outcome(_log([9.0, 5.5, 5.4], [0.5, 0.02, 0.0], [3, 0.5, 0.5]), _scenario())
    assert clean["success"] and np.isnan(clean["contact_after_s"])


def test_the_failed_criterion_is_named():
    far = capture_outcome(_log([9.0, 6.0, 5.8], [0.5, 0.0, 0.0], [3, 1, 1]), _scenario())
    assert not far["success"] and far["reason"].startswith("position")
    assert far["position_error_m"] == pytest.approx(0.4, abs=1e-12)
    fast = capture_outcome(_log([9.0, 5.5, 5.4], [0.5, 0.05, 0.04], [3, 1, 1]), _scenario())
    assert not fast["success"] and fast["reason"].startswith("speed")
