"""The shoot-out's task (campaign `shootout`, issue 22): 200 starts drawn once and flown by
every method truth-fed and on the estimate, judged by one capture criterion."""

import collections

import numpy as np

from rpod.diagrams.mission import Capture
from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs

CAMPAIGN = load_campaign("shootout")
RUNS = plan_runs(CAMPAIGN)
METHOD_KEYS = ("controller", "navigation")


def _start(run) -> dict:
    return {k: v for k, v in run.overrides.items() if k not in METHOD_KEYS}


def test_every_method_flies_the_same_200_starts_truth_fed_and_estimated():
    by_case = collections.defaultdict(list)
    for run in RUNS:
        by_case[run.case].append(run)
    assert set(by_case) == {
        "soft_capture",
        "soft_capture_ekf",
        "coupled_nmpc",
        "coupled_nmpc_ekf",
        "los_corridor",
        "los_corridor_ekf",
        "hold_point_pd",
        "hold_point_pd_ekf",
    }
    starts = [
        [_start(r) for r in sorted(runs, key=lambda r: r.sample_index)] for runs in by_case.values()
    ]
    assert all(len(s) == 200 for s in starts)
    assert all(s == starts[0] for s in starts[1:])  # common random numbers
    assert len({r.run_id for r in RUNS}) == len(RUNS)


def test_the_starts_are_the_task_s_and_every_run_is_judged_by_capture():
    for run in RUNS[:200]:
        scenario = apply_overrides(CAMPAIGN.base, run.overrides)
        rate = np.linalg.norm(scenario.target.w_IT_T_deg_s)
        assert 0.5 <= rate <= 8.0
        assert 15.0 <= np.linalg.norm(scenario.chaser.p_LC_L) <= 50.0
        assert scenario.mission == Capture(0.35, 0.03, True)
        assert scenario.thrusters.layout == "rcs_cube_12" and scenario.thrusters.pwm
        assert scenario.orbit.gravity == "two_body_j2"
