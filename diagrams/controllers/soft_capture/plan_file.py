"""Paper 000's plan as `rpod plan` writes it: the arrays of plan.npz, the summary and figures.

Owns: `plan_output` (a `ScenarioPlan` -> the seam's `PlanOutput`), `plan_arrays` and
`plan_summary`. Does not own: planning (planning.py), the figures (plan_figures.py) or writing
the folder (rpod.scenarios.plan, the same for every planner).

plan.npz: t [N], x [N, 6] (p_LC_L, v_LC_L), u [N-1, 3] (force in L, N), q_LT [N, 4], w_IT_T
[N, 3], q_LC [N, 4], alpha [N], alpha_check [N] (the checker's LP), rho [N], slack [N],
A_chaser, b_chaser, V_chaser, A_target, b_target, V_target (polytopes in C and T; V: vertices),
D_c, D_t, x0, and every Table I parameter under its symbol (n, m, dt, gamma, psi, U_max, r_max,
v_max, omega_max, eps_p, eps_v, theta_dock [rad], N_dock, alpha_min, i_max). A failed search
writes its last feasible iterate (it fails the hard test) or empty arrays (N = 0).

summary.json: the plan's status and reason, whether it passed (the planner's success and the
independent check), N, time_to_capture_s, the SCP's iterations and solve times, cost, fuel,
delta-v, min_alpha, the horizons tried, eps_p and eps_v, and the checker's report under `check`
(None without a plan of N >= 2 knots).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rpod.diagrams.controller_seam import PlanOutput
from rpod.diagrams.controllers.soft_capture.planning import ScenarioPlan
from rpod.models.config import ConfigError
from rpod.planners.soft_capture import PlanStatus


def _finite(value):
    """A float, or None when it is not finite (strict JSON has no NaN)."""
    value = float(value)
    return value if math.isfinite(value) else None


def plan_arrays(result, alpha_check: np.ndarray | None = None) -> dict:
    """The arrays of plan.npz (module docstring)."""
    plan, config = result.plan, result.config
    arrays = {
        "t": plan.t,
        "x": plan.x,
        "u": plan.u,
        "q_LT": plan.q_LT,
        "w_IT_T": plan.w_IT_T,
        "q_LC": plan.q_LC,
        "alpha": plan.alpha,
        "rho": plan.rho,
        "slack": plan.slack,
        "alpha_check": alpha_check if alpha_check is not None else np.full(plan.N, np.nan),
        "A_chaser": result.chaser_hull.A,
        "b_chaser": result.chaser_hull.b,
        "V_chaser": result.chaser_hull.vertices,
        "A_target": result.target_hull.A,
        "b_target": result.target_hull.b,
        "V_target": result.target_hull.vertices,
        "x0": result.x0,
    }
    arrays.update(config.symbols())  # n, m, dt, ..., D_c, D_t (Table I symbols)
    return {key: np.asarray(value) for key, value in arrays.items()}


def plan_summary(result, report) -> dict:
    """summary.json's entries after the status, reason and verdict (module docstring)."""
    plan, config = result.plan, result.config
    summary = {
        "N": int(plan.N),
        "time_to_capture_s": (plan.N - 1) * config.dt_s if plan.N else None,
        "scp_iterations": int(plan.scp_iterations),
        "solve_time_s": [float(s) for s in plan.solve_time_s],
        "step_time_s": [float(s) for s in plan.step_time_s],
        "total_solve_time_s": float(plan.total_solve_time_s),
        "wall_time_s": float(result.wall_time_s),
        "cost": _finite(plan.cost),
        "fuel_l1_N": float(plan.fuel_l1_N),
        "delta_v_m_s": float(
            np.linalg.norm(plan.u, axis=1).sum() * config.dt_s / config.chaser_mass_kg
        ),
        "min_alpha": _finite(plan.min_alpha),
        "attempts": [dataclasses.asdict(a) for a in plan.attempts],
        "eps_p": config.capture_position_tol_m,
        "eps_v": config.capture_speed_tol_m_s,
    }
    if report is None:
        summary["check"] = None
    else:
        summary["check"] = {
            "passed": report.passed(),
            "violations": {k: float(v) for k, v in report.violations().items()},
            **{k: _finite(v) for k, v in report.summary().items()},
        }
    return summary


def _drawable(draw):
    """A plan figure that is drawn only for a plan of at least two knots."""
    return lambda arrays, title: draw(arrays, title) if len(arrays["t"]) >= 2 else None


def plan_output(result: ScenarioPlan) -> PlanOutput:
    """What `rpod plan` writes of a soft-capture plan; ConfigError('target', reason) when no
    plan could be made at all (the target prediction failed)."""
    from rpod.diagrams.controllers.soft_capture import plan_figures

    if result.plan is None:  # a validated scenario's prediction does not fail; say so if it did
        raise ConfigError("target", result.checked.reason)
    report = result.checked.report  # the independent check (any plan of N >= 2 knots)
    status = result.checked.status
    passed = status is PlanStatus.SUCCESS and report is not None and report.passed()
    verdict = "not run (no plan)" if report is None else "passed" if report.passed() else "FAILED"
    return PlanOutput(
        status=status.value,
        passed=passed,
        reason=f"N = {result.plan.N}, independent check {verdict}"
        + ("" if passed or not result.checked.reason else f": {result.checked.reason}"),
        arrays=plan_arrays(result, None if report is None else report.alpha_check),
        summary=plan_summary(result, report),
        figures={name: _drawable(draw) for name, draw in plan_figures.FIGURES.items()},
    )
