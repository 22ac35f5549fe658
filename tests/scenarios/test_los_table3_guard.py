"""Guards of paper 004's Table 3 outcomes as rpod flies them (campaign `los_table3`).

The committed table (benchmarks/results/los_table3.md) has every start inside r_sync held with
zero corridor violations (15/15) and every start outside violating the corridor (15/15; the
paper: "No" for each). By default five inside starts are flown (~2 s each), one per omega_t of
1-5 deg/s with every a_max among them, and three outside starts, one per omega_t of 2, 3 and
5 deg/s; `pytest -m slow` flies all 30.
"""

import pytest

from rpod.diagrams.simulate import simulate
from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs

CAMPAIGN = load_campaign("los_table3")
RUNS = {run.case: run for run in plan_runs(CAMPAIGN)}
INSIDE = sorted(case for case in RUNS if case.endswith("_inside"))
OUTSIDE = sorted(case for case in RUNS if case.endswith("_outside"))
INSIDE_DEFAULT = [
    "w1_a0.10_inside",
    "w2_a0.02_inside",
    "w3_a0.05_inside",
    "w4_a0.10_inside",
    "w5_a0.02_inside",  # the smallest r_sync: a 1.3 m hold
]
OUTSIDE_DEFAULT = ["w3_a0.10_outside"]  # one representative; the rest: pytest -m slow


def _summary(case: str) -> dict:
    return simulate(apply_overrides(CAMPAIGN.base, RUNS[case].overrides)).summary


def test_the_campaign_has_the_papers_fifteen_combinations_twice():
    assert len(INSIDE) == len(OUTSIDE) == 15
    assert set(INSIDE_DEFAULT) <= set(INSIDE) and set(OUTSIDE_DEFAULT) <= set(OUTSIDE)


def _assert_held(cases: list[str]) -> None:
    failures = []
    for case in cases:
        summary = _summary(case)
        if not (summary["mission"]["success"] and summary["los_violation_depth_m"] == 0.0):
            failures.append(f"{case}: {summary['mission']['outcome']}")
    assert not failures, failures


def test_starts_inside_r_sync_are_held_without_a_violation():
    _assert_held(INSIDE_DEFAULT)


@pytest.mark.slow
def test_every_other_start_inside_r_sync_is_held_without_a_violation():
    _assert_held(sorted(set(INSIDE) - set(INSIDE_DEFAULT)))


def _assert_violated(case: str) -> None:
    summary = _summary(case)
    assert not summary["los_start_inside_sync_range"]
    assert summary["los_violation"] and summary["los_violation_depth_m"] > 1.0, case
    assert summary["mission"]["success"] is False, summary["mission"]["outcome"]


@pytest.mark.parametrize("case", OUTSIDE_DEFAULT)
def test_starts_outside_r_sync_violate_the_corridor(case):
    _assert_violated(case)


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(set(OUTSIDE) - set(OUTSIDE_DEFAULT)))
def test_every_other_start_outside_r_sync_violates_the_corridor(case):
    _assert_violated(case)
