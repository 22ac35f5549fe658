"""Paper 003's plan as `rpod plan` writes it: plan.npz's arrays, the summary and a figure.

Owns: `plan_output` (the plan from the scenario's initial state, planning.plan_scenario, as the
seam's `PlanOutput`). Does not own: planning (planning.py), the checker
(rpod.planners.planar_approach_check) or writing the folder (rpod.scenarios.plan).

plan.npz: t [N+1] (knot times, s), x [N+1, 6] ([x, y, theta, v_x, v_y, omega] in W),
wrench [N, 3] ([F_x, F_y, tau] in W, held on each step), keepout_state [N+1] (1 or 2), x0 [6],
goal_position [2], theta_finish, omega_target, chaser_side, target_side (m, rad, rad/s).
summary.json: the status, whether it passed (a success the independent check passed),
duration_s, cost and its terms, terminal_position_error_m, the candidates tried (duration,
status, solver word, time, iterations), total solve time, and the checker's report under
`check` (None without a flyable plan).
"""

from __future__ import annotations

import math

import numpy as np

from rpod.diagrams.controller_seam import PlanOutput
from rpod.diagrams.controllers.planar_approach.planning import plan_scenario


def _finite(value) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def _json(value):
    """A checker report entry as JSON data (numpy scalars and non-finite floats made safe)."""
    if isinstance(value, (bool, str)) or value is None:
        return value
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return _finite(value)
    if isinstance(value, dict):
        return {str(k): _json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_json(v) for v in value]
    return str(value)


def plan_output(scenario, closed_loop: bool = False) -> PlanOutput:
    """The planar plan from the initial state (the closed loop plans the same one: paper 003's
    method has no separate margins, so `closed_loop` changes nothing)."""
    config, x0, plan, check = plan_scenario(scenario)
    passed = bool(plan.success and check is not None and check.get("passed"))
    verdict = "not run (no plan)" if check is None else "passed" if check["passed"] else "FAILED"
    duration = _finite(plan.duration_s)
    arrays = {
        "t": plan.t_knots,
        "x": plan.x_knots,
        "wrench": plan.wrench_knots,
        "keepout_state": plan.keepout_state,
        "x0": x0,
        "goal_position": plan.goal_position,
        "theta_finish": plan.theta_finish,
        "omega_target": config.omega_target_rad_s,
        "chaser_side": config.chaser_side_m,
        "target_side": config.target_side_m,
    }
    summary = {
        "duration_s": duration,
        "solver_message": plan.solver_message,
        "cost": _finite(plan.cost),
        "cost_terms": _json(plan.cost_terms),
        "terminal_position_error_m": _finite(plan.terminal_position_error_m),
        "candidates": [
            {
                "duration_s": _finite(c.duration_s),
                "status": c.status.value,
                "solver_message": c.solver_message,
                "solve_time_s": float(c.solve_time_s),
                "iterations": int(c.iterations),
            }
            for c in plan.candidates
        ],
        "total_solve_time_s": float(sum(c.solve_time_s for c in plan.candidates)),
        "check": None if check is None else _json(check),
    }
    duration_text = "no duration" if duration is None else f"T = {duration:.1f} s"
    return PlanOutput(
        status=plan.status.value,
        passed=passed,
        reason=f"{duration_text}, independent check {verdict}",
        arrays=arrays,
        summary=summary,
        figures={"plan_path.png": _figure_plan_path},
    )


def _figure_plan_path(arrays, title: str):
    """The planned path in W with the chaser's and the target's squares at start and arrival."""
    from matplotlib.figure import Figure

    from rpod.diagrams.controllers.planar_approach.figures import square_corners

    x, t = np.asarray(arrays["x"]), np.asarray(arrays["t"])
    if len(x) < 2:
        return None
    fig = Figure(figsize=(6, 6), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(x[:, 0], x[:, 1], color="tab:blue", marker=".", markersize=3, label="planned path")
    for index, style, label in ((0, ":", "start"), (-1, "-", "arrival")):
        chaser = square_corners(x[index, :2], x[index, 2], float(arrays["chaser_side"]))
        yaw = float(arrays["omega_target"]) * float(t[index])
        target = square_corners([0.0, 0.0], yaw, float(arrays["target_side"]))
        ax.plot(*chaser.T, style, color="tab:blue", label=f"chaser at {label}")
        ax.plot(*target.T, style, color="tab:red", label=f"target at {label}")
    goal = np.asarray(arrays["goal_position"])
    ax.plot(*goal, "x", color="black", label="goal")
    ax.set(xlabel="x_W [m]", ylabel="y_W [m]", title=f"{title}: plan (T = {t[-1]:.1f} s)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize="small")
    return fig
