"""One soft-capture plan to a folder: plan.npz, summary.json, plots/, scenario.yaml (`rpod plan`).

Owns: `plan_scenario` (paper 000's planner on a scenario's initial state, no simulation) and
`plan_to_folder`, which writes the plan so that a folder is either complete or absent (a hidden
staging folder renamed into place, as `rpod.scenarios.run.run_to_folder` does), under the same
rules for the output folder (`rpod.scenarios.run.check_out_dir`: checked before planning, and a
folder rpod did not write is only replaced with `overwrite`).
Does not own: the planner (rpod.planners), the plots
(rpod.diagrams.controllers.soft_capture.plan_figures), or the command line (cli.py).

What is planned (today the !SoftCapture plug-in's `make_plan`,
rpod.diagrams.controllers.soft_capture.plan_scenario). The planner's config (its settings as
written, Table I in the bundled scenario, with the problem data derived from the scenario), from the scenario's initial state: x0 = [chaser.p_LC_L,
chaser.v_LC_L], the target's initial attitude in LVLH and body rate, the chaser's initial
attitude as the pointing law's start, the target inertia for the prediction (torque-free Euler
equations with the LVLH frame turning at the planner's n), and the scenario's true polytopes.
The closed loop (`rpod run`) plans its first plan from the same state but with eps_p, eps_v
scaled by `plan_tolerance_fraction` and the hulls scaled by 1 + `collision_margin` (margins for
tracking error and for the motion between knots); `closed_loop=True` plans that one instead (the
file's polytopes are then the scaled ones the plan was checked against). Every plan with N >= 2
knots is re-checked by the independent checker (rpod.planners.plan_check); its report is in
summary.json.

plan.npz: t [N], x [N, 6] (p_LC_L, v_LC_L), u [N-1, 3] (force in L, N), q_LT [N, 4], w_IT_T
[N, 3], q_LC [N, 4], alpha [N], alpha_check [N] (the checker's LP), rho [N], slack [N],
A_chaser, b_chaser, V_chaser, A_target, b_target, V_target (polytopes in C and T; V: vertices),
D_c, D_t, x0, and every Table I parameter under its symbol (n, m, dt, gamma, psi, U_max, r_max,
v_max, omega_max, eps_p, eps_v, theta_dock [rad], N_dock, alpha_min, i_max). A failed search
writes its last feasible iterate (it fails the hard test) or empty arrays (N = 0).
"""

from __future__ import annotations

import dataclasses
import json
import math
import pathlib

import numpy as np

from rpod.diagrams import controller_seam
from rpod.diagrams.controllers.soft_capture.plan_figures import write_plan_plots
from rpod.diagrams.scenario import Scenario
from rpod.scenarios.loader import ScenarioFileError, dump_scenario
from rpod.scenarios.run import check_out_dir, staged_folder


def _finite(value):
    """A float, or None when it is not finite (strict JSON has no NaN)."""
    value = float(value)
    return value if math.isfinite(value) else None


def plan_scenario(name: str, scenario: Scenario, closed_loop: bool = False):
    """The scenario's controller's plan from the initial state (its plug-in's `make_plan`).

    Raises:
        ScenarioFileError: If the scenario's controller has no planner (one line naming the
            field, as the command line reports bad input).
    """
    plugin = controller_seam.plugin_for(scenario.controller)
    if plugin is None or plugin.make_plan is None:
        with_planner = [f"!{p.tag}" for p in controller_seam.controller_plugins() if p.make_plan]
        got = "none" if plugin is None else f"!{plugin.tag}"
        raise ScenarioFileError(
            f"{name}: controller: `rpod plan` needs a controller with a planner "
            f"({', '.join(with_planner)}), got {got}"
        )
    return plugin.make_plan(scenario, closed_loop)


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


def plan_summary(name: str, result, report) -> dict:
    """The content of summary.json."""
    plan, config = result.plan, result.config
    summary = {
        "scenario": name,
        "status": result.checked.status.value,
        "reason": result.checked.reason,
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


def plan_to_folder(
    name: str,
    scenario: Scenario,
    out_dir: pathlib.Path,
    closed_loop: bool = False,
    overwrite: bool = False,
) -> dict:
    """Plans `scenario` and writes plan.npz, summary.json, plots/ and scenario.yaml into out_dir.

    Args:
        name: The scenario's name (titles, summary).
        scenario: A validated scenario with a soft_capture controller.
        out_dir: The folder to write (replaced whole, atomically, when complete).
        closed_loop: Plan with the closed loop's tightened tolerances (module docstring).
        overwrite: Also replace a folder rpod did not write (`--overwrite`).

    Returns:
        The summary (summary.json's content); ``summary["status"]`` is the planner's status, or
        "check_failed" when the checker rejected the planner's success.

    Raises:
        ScenarioFileError: If the scenario has no soft-capture controller, or out_dir may not
            be written (checked before planning).
    """
    check_out_dir(out_dir, overwrite)
    result = plan_scenario(name, scenario, closed_loop)
    if result.plan is None:  # a validated scenario's prediction does not fail; say so if it did
        raise ScenarioFileError(f"{name}: target: {result.checked.reason}")
    report = result.checked.report  # the independent check (any plan of N >= 2 knots)
    with staged_folder(out_dir, overwrite) as staging:
        arrays = plan_arrays(result, None if report is None else report.alpha_check)
        np.savez_compressed(staging / "plan.npz", **arrays)
        (staging / "scenario.yaml").write_text(dump_scenario(scenario))
        summary = plan_summary(name, result, report)
        summary["plots"] = [p.name for p in write_plan_plots(arrays, staging / "plots", name)]
        # summary.json last: its presence marks a complete plan inside the folder too.
        (staging / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary
