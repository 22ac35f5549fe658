"""The compute per control step (rpod.systems.step_timer) and its summary entries."""

import time

import numpy as np

from rpod.diagrams.simulate import simulate
from rpod.scenarios.loader import load_scenario
from rpod.systems.step_timer import StepTimer, compute_summary


def test_each_call_is_timed_and_its_result_passed_on():
    timer = StepTimer()

    def step(x):
        time.sleep(0.002 * x)
        return 10 * x

    timed = timer.timed(step)
    assert [timed(1), timed(2), timed(0)] == [10, 20, 0]
    durations = timer.durations_s
    assert durations.shape == (3,)
    assert durations[0] >= 0.002 and durations[1] >= 0.004 and durations[1] > durations[2]
    summary = compute_summary(timer)
    assert summary["control_steps"] == 3
    assert summary["control_step_ms_max"] == 1e3 * durations.max()
    assert summary["control_step_ms_p50"] == np.median(1e3 * durations)
    timer.reset()
    assert compute_summary(timer) == {
        "control_steps": 0,
        "control_step_ms_p50": None,
        "control_step_ms_p99": None,
        "control_step_ms_max": None,
    }


def test_a_call_that_raises_is_timed_too():
    timer = StepTimer()

    def fail():
        raise ValueError("no")

    try:
        timer.timed(fail)()
    except ValueError:
        pass
    assert timer.durations_s.size == 1


def test_a_run_reports_one_step_per_control_period():
    _, scenario = load_scenario("hold_point")
    scenario.duration_s = 2.0
    summary = simulate(scenario).summary
    period = scenario.controller.control_period_s
    # The initialisation update and one per period from t = 0 to before the end (Drake does
    # not handle the events due at the final time).
    assert summary["control_steps"] == 1 + round(scenario.duration_s / period)
    assert 0 < summary["control_step_ms_p50"] <= summary["control_step_ms_p99"]
    assert summary["control_step_ms_p99"] <= summary["control_step_ms_max"]
