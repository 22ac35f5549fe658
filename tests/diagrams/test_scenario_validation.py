"""validate_scenario: the cases a hostile but fair user found (issue 8) are field errors naming
the field, and the bounds on work refuse what would hang a run or exhaust memory."""

import numpy as np
import pytest

from rpod.diagrams.scenario import (
    MAX_DURATION_S,
    MAX_SAMPLES,
    ChaserConfig,
    Scenario,
    ScenarioError,
    TargetConfig,
    ThrustersConfig,
    starts_in_contact,
    validate_scenario,
)
from rpod.diagrams.simulate import simulate
from rpod.models.orbit import OrbitConfig


def _with(**changes) -> Scenario:
    """The default scenario with fields replaced; 'block__field' names a field of a block."""
    scenario = Scenario()
    for key, value in changes.items():
        block, _, field = key.partition("__")
        if "__" in field:  # block__sub__field
            sub, _, field = field.partition("__")
            setattr(getattr(getattr(scenario, block), sub), field, value)
        elif field:
            setattr(getattr(scenario, block), field, value)
        else:
            setattr(scenario, block, value)
    return scenario


# (id, changes, the field the error must name, a phrase of the message)
BAD = [
    ("duration_1e308", {"duration_s": 1e308}, "duration_s", "at most"),
    ("log_period_1e-9", {"log_period_s": 1e-9}, "log_period_s", "at most"),
    ("log_period_over_duration", {"log_period_s": 700.0}, "log_period_s", "must not exceed"),
    ("subdivisions_1e12", {"thrusters__subdivisions": 10**12}, "thrusters.subdivisions", "in [1"),
    ("modulation_unknown", {"thrusters__modulation": "sigma"}, "thrusters.modulation", "one of"),
    (
        "hysteresis_1",
        {"thrusters__schmitt_hysteresis": 1.0},
        "thrusters.schmitt_hysteresis",
        "[0, 1)",
    ),
    (
        "delta_sigma_min_on",
        {"thrusters__modulation": "delta_sigma", "thrusters__min_on_slots": 3},
        "thrusters.min_on_slots",
        "single slots",
    ),
    ("spin_1e6_deg_s", {"target__w_IT_T_deg_s": [1e6, 0, 0]}, "target.w_IT_T_deg_s", "360"),
    ("chaser_spin", {"chaser__w_IC_C_deg_s": [0, 500.0, 0]}, "chaser.w_IC_C_deg_s", "360"),
    ("altitude_1e308", {"orbit__altitude_m": 1e308}, "orbit.altitude_m", "must be in"),
    ("p_LC_L_1e308", {"chaser__p_LC_L": [1e308, 0, 0]}, "chaser.p_LC_L", "at most"),
    ("v_LC_L_1e308", {"chaser__v_LC_L": [0, 1e308, 0]}, "chaser.v_LC_L", "at most"),
    ("inclination_181", {"orbit__inclination_deg": 181.0}, "orbit.inclination_deg", "[0, 180]"),
    ("inclination_negative", {"orbit__inclination_deg": -1.0}, "orbit.inclination_deg", "[0, 180]"),
    ("start_at_centre", {"chaser__p_LC_L": [0.0, 0.0, 0.0]}, "chaser.p_LC_L", "inside the target"),
    ("start_inside_box", {"chaser__p_LC_L": [0.5, -0.3, 0.2]}, "chaser.p_LC_L", "inside"),
    ("bodies_overlap", {"chaser__p_LC_L": [0.0, -1.7, 0.0]}, "chaser.p_LC_L", "contact"),
    (
        "both_attitudes",
        {"target__q_LT": [1, 0, 0, 0], "target__rpy_LT_deg": [0, 0, 10.0]},
        "target.q_LT",
        "both",
    ),
    ("non_unit_quaternion", {"target__q_LT": [0.9, 0.0, 0.0, 0.0]}, "target.q_LT", "unit"),
    (
        "publish_period_tiny",
        {"visualization__publish_period_s": 1e-9},
        "visualization.publish_period_s",
        "at most",
    ),
    (
        "max_step_tiny",
        {"simulator__max_step_size": 1e-12},
        "simulator.max_step_size",
        "at most",
    ),
    (
        "rk2_with_error_control",
        {"simulator__integration_scheme": "runge_kutta2"},
        "simulator.use_error_control",
        "no error estimate",
    ),
    ("start_time", {"simulator__start_time": 5.0}, "simulator.start_time", "must be 0"),
    (
        "control_period_tiny",
        {"controller__control_period_s": 1e-9},
        "controller.control_period_s",
        "at most",
    ),
]


@pytest.mark.parametrize("case, changes, field, phrase", BAD, ids=[c[0] for c in BAD])
def test_bad_field_is_a_field_error(case, changes, field, phrase):
    with pytest.raises(ScenarioError) as raised:
        validate_scenario(_with(**changes))
    assert raised.value.field == field, str(raised.value)
    assert phrase in raised.value.message
    assert len(str(raised.value)) < 300  # one short line


def test_limits_themselves_are_accepted():
    scenario = Scenario(
        duration_s=MAX_DURATION_S,
        log_period_s=MAX_DURATION_S / MAX_SAMPLES,
        controller=None,
        thrusters=ThrustersConfig(enabled=False),
    )
    scenario.visualization.publish_period_s = MAX_DURATION_S / MAX_SAMPLES
    scenario.simulator.max_step_size = 10.0
    validate_scenario(scenario)


def test_nearly_unit_quaternion_as_a_person_writes_it_is_accepted():
    validate_scenario(_with(target__q_LT=[0.7071, 0.7071, 0.0, 0.0]))


def test_contact_check_agrees_with_the_boxes():
    """Default boxes: target 2 m, chaser 1.5 m, both aligned with L: they touch at 1.75 m."""
    assert starts_in_contact(_with(chaser__p_LC_L=[0.0, -1.74, 0.0]))
    assert not starts_in_contact(_with(chaser__p_LC_L=[0.0, -1.76, 0.0]))
    # Turned 45 deg about z, the target's corner reaches sqrt(2) m along y.
    turned = _with(chaser__p_LC_L=[0.0, -2.0, 0.0], target__rpy_LT_deg=[0.0, 0.0, 45.0])
    assert starts_in_contact(turned)
    assert not starts_in_contact(_with(chaser__p_LC_L=[0.0, -2.0, 0.0]))


def _coast(duration_s: float, log_period_s: float) -> Scenario:
    return Scenario(
        duration_s=duration_s,
        log_period_s=log_period_s,
        orbit=OrbitConfig(gravity="free_space"),
        chaser=ChaserConfig(p_LC_L=[0.0, -30.0, 0.0], v_LC_L=[0.1, 0.0, 0.0]),
        target=TargetConfig(w_IT_T_deg_s=[0.0, 0.0, 0.0]),
        thrusters=ThrustersConfig(enabled=False),
        controller=None,
    )


def test_metrics_come_from_the_simulation_end_not_the_last_log_sample():
    """duration 10.5 s with 4 s logging: the periodic samples stop at 8 s; the summary must
    still describe t = 10.5 s. Free space, no thrust: p(t) = p0 + v0 t exactly."""
    result = simulate(_coast(10.5, 4.0))
    summary, log = result.summary, result.log
    assert summary["sim_time_s"] == pytest.approx(10.5, abs=1e-12)
    np.testing.assert_allclose(log["t"], [0.0, 4.0, 8.0, 10.5], atol=1e-12)
    # Tolerance: runge_kutta3 at accuracy 1e-6 on a straight line is exact to rounding.
    np.testing.assert_allclose(summary["final_p_LC_L"], [1.05, -30.0, 0.0], atol=1e-9)
    assert summary["final_range_m"] == pytest.approx(np.hypot(1.05, 30.0), abs=1e-9)


def test_final_sample_is_not_doubled_when_duration_is_a_log_time():
    log = simulate(_coast(8.0, 4.0)).log
    np.testing.assert_allclose(log["t"], [0.0, 4.0, 8.0], atol=1e-12)
