"""One capture criterion for every method (`mission: !Capture`): judged on the safety monitor's
capture outputs whatever flies, the run ended at its capture, the controller's own verdict kept
beside it, and a contact before the capture never a success."""

import dataclasses
import json

import numpy as np
import pytest

from rpod.diagrams.mission import Capture, ControllerCriterion, capture_verdict
from rpod.diagrams.scenario import validate_scenario
from rpod.diagrams.simulate import simulate
from rpod.models.config import ConfigError
from rpod.scenarios.loader import dump_scenario, load_scenario, parse_scenario


@pytest.fixture(scope="module")
def soft_capture_both_ways():
    """The bundled soft capture judged by its own criterion and by the common one."""
    _, scenario = load_scenario("soft_capture")
    own = simulate(scenario)
    common = simulate(dataclasses.replace(scenario, mission=Capture()))
    return scenario, own, common


def test_the_default_is_each_controller_s_own_criterion():
    _, scenario = load_scenario("hold_point")
    assert isinstance(scenario.mission, ControllerCriterion)


def test_soft_capture_is_judged_alike_and_the_run_ends_at_its_capture(soft_capture_both_ways):
    scenario, own, common = soft_capture_both_ways
    mission = common.summary["mission"]
    assert mission["criterion"] == "capture" and mission["success"] is True
    assert own.summary["mission"]["criterion"] == "controller"
    # Its own criterion reads the 0.1 s log samples; the common one every step, and stops there.
    captured_s = mission["capture"]["time_s"]
    assert own.summary["capture"]["time_s"] - scenario.log_period_s <= captured_s
    assert captured_s <= own.summary["capture"]["time_s"]
    assert common.log["t"][-1] == pytest.approx(captured_s)
    assert common.summary["stopped_early"].startswith("captured at")
    assert common.log["capture_distance_m"][-1] <= 0.35
    assert common.log["capture_speed_m_s"][-1] <= 0.03
    # Up to the capture the two runs are the same run.
    same = common.log["t"] < captured_s - 1e-9
    np.testing.assert_array_equal(common.log["p_LC_L"][same], own.log["p_LC_L"][: same.sum()])


def test_a_controller_with_another_mission_is_judged_by_capture_and_keeps_its_own_verdict():
    _, scenario = load_scenario("hold_point")  # holds 10 m beyond the port: never captures
    summary = simulate(dataclasses.replace(scenario, mission=Capture(), duration_s=60.0)).summary
    mission = summary["mission"]
    assert mission["success"] is False and mission["criterion"] == "capture"
    assert mission["outcome"].startswith("NOT captured: position:")
    assert mission["capture"]["position_error_m"] > 10.0
    assert mission["controller_success"] is False  # its hold is not reached in 60 s either
    assert summary["stopped_early"] is None


def test_the_hold_point_flown_onto_the_port_captures_paper_000_s_start():
    """The PD baseline of the shoot-out (issue 22): !HoldPoint with `capture` holds the
    chaser's capture point on the port, and the common criterion judges it."""
    from rpod.diagrams.controllers.hold_point.config import HoldPoint

    _, scenario = load_scenario("soft_capture")
    baseline = HoldPoint(hold_distance_m=0.0, capture=True)
    summary = simulate(
        dataclasses.replace(scenario, controller=baseline, mission=Capture(), duration_s=150.0)
    ).summary
    mission = summary["mission"]
    assert mission["success"] is True, mission["outcome"]
    assert summary["sim_time_s"] == pytest.approx(mission["capture"]["time_s"])
    assert 60.0 < mission["capture"]["time_s"] < 150.0  # slower than the planner's 48.5 s


def _log(distance, speed, separation):
    return {
        "t": np.arange(len(distance), dtype=float),
        "capture_distance_m": np.array(distance, float),
        "capture_speed_m_s": np.array(speed, float),
        "separation_m": np.array(separation, float),
    }


def test_capture_is_the_first_sample_within_both_tolerances():
    verdict = capture_verdict(
        _log([2.0, 0.3, 0.2, 0.1], [0.1, 0.05, 0.02, 0.01], [1.0, 0.5, 0.4, 0.3]), Capture()
    )
    assert verdict["success"] and verdict["time_s"] == 2.0
    assert verdict["position_error_m"] == 0.2 and verdict["speed_error_m_s"] == 0.02


def test_a_contact_before_the_capture_fails_it():
    verdict = capture_verdict(_log([2.0, 0.3, 0.2], [0.1, 0.05, 0.02], [1.0, 0.0, 0.4]), Capture())
    assert verdict["success"] is False  # a Python bool: summary.json is written with json
    assert verdict["reason"].startswith("contact:") and verdict["time_s"] == 1.0
    json.dumps(verdict)  # numpy's bool here crashed two shoot-out runs


@pytest.mark.parametrize(
    ("distance", "speed", "reason"),
    [
        ([2.0, 0.5, 0.4], [0.01, 0.01, 0.01], "position: "),
        ([2.0, 0.3, 0.2], [0.1, 0.05, 0.04], "speed: "),
    ],
)
def test_a_missed_capture_says_which_tolerance_and_by_how_much(distance, speed, reason):
    verdict = capture_verdict(_log(distance, speed, [1.0] * 3), Capture())
    assert not verdict["success"] and verdict["reason"].startswith(reason)
    assert ("0.400 m" if reason == "position: " else "0.0400 m/s") in verdict["reason"]


def test_the_block_reads_from_yaml_and_its_bad_fields_are_named():
    _, scenario = load_scenario("soft_capture")
    text = dump_scenario(dataclasses.replace(scenario, mission=Capture(position_tol_m=0.2)))
    assert "mission: !Capture" in text
    assert parse_scenario(text).mission == Capture(position_tol_m=0.2)
    bad = dataclasses.replace(scenario, mission=Capture(speed_tol_m_s=-0.1))
    with pytest.raises(ConfigError) as caught:
        validate_scenario(bad)
    assert caught.value.field == "mission.speed_tol_m_s"
