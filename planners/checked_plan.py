"""One predict-plan-check path for paper 000's soft capture: `rpod plan` and the closed loop.

Owns: `predict_plan_check`, which predicts the target's attitude over the horizon (torque-free
Euler equations, L turning at the orbit's n), calls the planner, and has every plan the planner
calls a success re-checked by the independent checker (rpod.planners.plan_check) against
exactly what it was planned with (config, hulls, prediction, start). Its `CheckedPlan` says
what came of it (a `PlanStatus`), never raising on a bad measurement or an infeasible start.
Does not own: the planner (soft_capture.py), the checker (plan_check.py), what a caller does
with a rejected plan (the closed loop falls back; `rpod plan` writes it for diagnosis).
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from rpod.planners.plan_check import DEFAULT_TOLERANCES, PlanCheckReport, check_plan
from rpod.planners.soft_capture import PlanStatus, SoftCapturePlan, SoftCapturePlanner
from rpod.planners.target_prediction import TargetPrediction, predict_target


@dataclasses.dataclass
class CheckedPlan:
    """What one predict-plan-check call gave.

    Attributes:
        status: the planner's status, or PREDICTION_FAILED, or CHECK_FAILED (the planner
            called it a success and the checker rejected it).
        reason: one line.
        plan: the planner's plan (None when the prediction failed).
        prediction: the target prediction it was planned against (None when that failed).
        report: the checker's report (None when not checked).
        wall_time_s: prediction and planning [s].
        check_time_s: the check [s] (0 when not checked).
    """

    status: PlanStatus
    reason: str
    plan: SoftCapturePlan | None = None
    prediction: TargetPrediction | None = None
    report: PlanCheckReport | None = None
    wall_time_s: float = 0.0
    check_time_s: float = 0.0

    @property
    def accepted(self) -> bool:
        """A plan to fly: the planner succeeded and the checker passed it."""
        return self.status is PlanStatus.SUCCESS

    def worst_violations(self) -> dict:
        """The checker's violations, a collision first, then by value / tolerance."""
        if self.report is None:
            return {}
        violations = self.report.violations()

        def severity(name):
            if name == "min_alpha":
                return math.inf
            limit = DEFAULT_TOLERANCES.get(name, DEFAULT_TOLERANCES["dynamics_residual"])
            value = violations[name]
            return value / limit if limit > 0 and math.isfinite(value) else math.inf

        return {
            name: float(violations[name]) for name in sorted(violations, key=severity, reverse=True)
        }


def predict_plan_check(
    planner: SoftCapturePlanner,
    x0,
    q_LT0,
    w_IT_T0,
    target_inertia,
    *,
    t0_s: float = 0.0,
    R_LC0=None,
    horizons: list[int] | None = None,
    check_unsuccessful: bool = False,
) -> CheckedPlan:
    """Predicts, plans and checks from one measured state (module docstring).

    Args:
        planner: the planner (its config, and its hulls, which the check uses too).
        x0: [p_LC_L, v_LC_L] (6) at t0_s.
        q_LT0: target attitude R_LT at t0_s (w, x, y, z).
        w_IT_T0: target body rate in T at t0_s [rad/s].
        target_inertia: (3, 3) in T [kg m^2], for the prediction.
        t0_s: the plan's start [s].
        R_LC0: the chaser attitude the pointing law starts from (None: the planner's default).
        horizons: the N to try (None: the config's whole search); the prediction covers the
            largest.
        check_unsuccessful: also check an unsuccessful plan of N >= 2 knots (for diagnosis;
            its status stays the planner's).
    """
    config = planner.config
    count = max(horizons) if horizons is not None else config.max_knots
    start = time.perf_counter()
    try:
        prediction = predict_target(
            np.asarray(q_LT0, dtype=float),
            np.asarray(w_IT_T0, dtype=float),
            target_inertia,
            t0_s + np.arange(count) * config.dt_s,
            n_orbit=config.mean_motion,
        )
    except (ValueError, RuntimeError) as error:
        return CheckedPlan(
            PlanStatus.PREDICTION_FAILED,
            str(error).splitlines()[0],
            wall_time_s=time.perf_counter() - start,
        )
    plan = planner.plan(np.asarray(x0, dtype=float), prediction, horizons=horizons, R_LC0=R_LC0)
    result = CheckedPlan(
        plan.status, plan.reason, plan, prediction, wall_time_s=time.perf_counter() - start
    )
    if plan.success or (check_unsuccessful and plan.N >= 2):
        check_start = time.perf_counter()
        result.report = check_plan(
            plan,
            config,
            prediction,
            x0=np.asarray(x0, dtype=float),
            chaser_hull=planner.chaser_hull,
            target_hull=planner.target_hull,
        )
        result.check_time_s = time.perf_counter() - check_start
        if plan.success and not result.report.passed():
            found = ", ".join(f"{k} = {v:.3g}" for k, v in result.worst_violations().items())
            result.status = PlanStatus.CHECK_FAILED
            result.reason = f"the planner's plan (N = {plan.N}) failed the plan check: {found}"
    return result
