"""Guards of the soft-capture planner's headline rate: plans on a fixed Sec. VI-B draw.

Each start is drawn by `sample_sec_vib_start` (seed fixed); every plan is re-checked by the
independent checker (plan_check: dynamics by expm, every constraint in its nonlinear form,
alpha by a separate LP). A plan counts when its status is success AND the checker finds no
violation and no collision. The benchmarks and the 250-run campaign give 100 % on such draws
(benchmarks/results/soft_capture.md: 30/30); measured here: 50/50 (seed 2026) and 250/250
(seed 250). A drop to 90 % fails both.
"""

import numpy as np
import pytest

from rpod.models.statistics import SuccessShare
from rpod.planners.plan_check import check_plan
from rpod.planners.soft_capture import (
    SoftCaptureConfig,
    SoftCapturePlanner,
    sample_sec_vib_start,
)

CONFIG = SoftCaptureConfig()


def _checked_share(count: int, seed: int) -> tuple[SuccessShare, list[str]]:
    planner = SoftCapturePlanner(CONFIG)
    rng = np.random.default_rng(seed)
    failures = []
    for i in range(count):
        x0, prediction = sample_sec_vib_start(rng, CONFIG)
        plan = planner.plan(x0, prediction)
        if plan.status != "success":
            failures.append(f"start {i}: {plan.status} ({plan.reason})")
            continue
        report = check_plan(plan, CONFIG, prediction, x0=x0)
        if report.violations() or not report.collision_free:
            failures.append(f"start {i}: checker {report.violations()}")
    return SuccessShare(count - len(failures), count), failures


def test_at_least_49_of_50_sec_vib_starts_plan_and_pass_the_checker():
    share, failures = _checked_share(50, seed=2026)
    assert share.successes >= 49, (share.percent_text(), failures)


@pytest.mark.slow
def test_at_least_245_of_250_sec_vib_starts_plan_and_pass_the_checker():
    share, failures = _checked_share(250, seed=250)
    assert share.successes >= 245, (share.percent_text(), failures)
