"""A handful of paper 004 Sec. 9 Monte Carlo starts, flown for real as the bundled campaign
plans them, classified as the paper classifies them: a start deep in the certified set flies
400 s with zero violations (feasible); one beyond r_sync is stopped at its first violation
(infeasible, the paper's early termination).

The campaign's 3900 runs are planned once, by a module fixture (~10-20 s of validation): at
import it made every `pytest` collection wait for them, whatever tests were asked for."""

import numpy as np
import pytest

from rpod.diagrams.scenario import validate_scenario
from rpod.diagrams.simulate import simulate
from rpod.planners import reachability as reach
from rpod.planners.reachability_mc import classify_run
from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs


@pytest.fixture(scope="module")
def planned():
    """(the bundled campaign, its planned runs)."""
    campaign = load_campaign("los_monte_carlo")
    return campaign, plan_runs(campaign)


def _run(planned, case: str, x: float, y: float):
    """The planned run of this case at the start nearest (x, y), simulated."""
    campaign, runs = planned
    candidates = [r for r in runs if r.case == case]
    run = min(
        candidates, key=lambda r: np.hypot(*(np.subtract(r.overrides["chaser.p_LC_L"][:2], (x, y))))
    )
    scenario = apply_overrides(campaign.base, run.overrides)
    validate_scenario(scenario)
    summary = simulate(scenario).summary
    return run, {"status": summary["status"], "metrics": summary}


def test_the_campaign_is_sec_9s_grid(planned):
    _, runs = planned
    assert len(runs) == 3900
    starts = {tuple(r.overrides["chaser.p_LC_L"]) for r in runs}
    assert len(starts) == 195
    ys = sorted({s[1] for s in starts})
    assert len(ys) == 15 and ys[0] == pytest.approx(20.0) and ys[-1] == pytest.approx(300.0)
    for y in ys:  # 13 per row, out to 0.95 of the half-width
        xs = sorted(s[0] for s in starts if s[1] == y)
        assert len(xs) == 13
        assert xs[-1] == pytest.approx(0.95 * np.tan(np.radians(30)) * y, abs=1e-3)


@pytest.mark.parametrize(
    "case, start, feasible",
    [
        ("w2_a0.10", (-7.3, 40.0), True),  # deep in X_nom at 2 deg/s, 0.10 m/s^2
        ("w2_a0.10", (60.0, 220.0), False),  # beyond r_sync = 164 m
        ("w5_a0.02", (0.0, 20.0), False),  # r_sync = 5.3 m: 20 m is far beyond it
    ],
)
def test_starts_are_classified_as_the_paper_does(planned, case, start, feasible):
    campaign, _ = planned
    run, row = _run(planned, case, *start)
    result, reason = classify_run(row, campaign.base.duration_s)
    assert result is feasible, reason
    metrics = row["metrics"]
    point = np.asarray(run.overrides["chaser.p_LC_L"])[None, :]
    omega = np.radians(run.overrides["target.w_IT_T_deg_s"][2])
    a_max = run.overrides["controller.a_max_m_s2"]
    if feasible:
        assert metrics["sim_time_s"] == pytest.approx(400.0) and not metrics["los_violation"]
        corridor = campaign.base.controller.corridor()
        terms = reach.GridSlack.on(reach.SafeStartGrid.at_points(point, corridor), corridor)
        assert reach.certified_mask(terms, omega, a_max).all()  # in X_nom, as chosen
    else:
        assert metrics["los_violation"] and metrics["stopped_early"]
        assert metrics["sim_time_s"] < 400.0
