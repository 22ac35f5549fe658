"""Paper 003's planar approach: a run's results, from its log and its plan (numpy only).

Owns: `planar_log` (the per-sample arrays the plug-in adds to log.npz), `planar_summary`
(summary.json's entries: tracking and terminal errors, keep-out and contact, fuel, switches),
`formulation_text`, `switch_count` and `plan_separation`.
Does not own: the plan (planning.py), the mission's verdict (mission.py), the figures
(figures.py) or the campaign tables (tables.py).

Thruster switches (`planar_switches`, OFF -> ON and ON -> OFF of every thruster, from OFF at
t = 0). Counted from the logged `thruster_on` when the log samples every PWM slot (exact for
every scheme); otherwise None: a log at the control period cannot say them (the PWM and the
logger sample the same instant an ulp apart in some periods, rpod.systems.pwm).
"""

import math

import numpy as np

from rpod.diagrams.controllers.planar_approach.config import PlanarApproach
from rpod.diagrams.controllers.planar_approach.planning import PlanarApproachRun
from rpod.diagrams.controllers.planar_approach.reference import hold_force_ratio
from rpod.diagrams.scenario import body_polytopes
from rpod.models import planar_approach as pa
from rpod.models.frames import rotations_from_wxyz
from rpod.models.shapes import separation_distance
from rpod.models.thrusters import STANDARD_GRAVITY_M_S2
from rpod.planners.planar_approach import PlanarApproachConfig


def formulation_text(config: PlanarApproachConfig, block: PlanarApproach) -> str:
    """The formulation a run planned and flew, in one line: the cost (eq. 5, with (5') and
    its weight), the State II switch, the goal constraints, the candidates, the tracker."""
    parts = [
        "eq. 5"
        if config.w_terminal_velocity == 0.0
        else f"eq. 5 + (5') w_v {config.w_terminal_velocity:g}",
        "State II facing the face" if config.state_ii_heading else "position-only switch",
    ]
    if config.goal_constraint:
        parts.append("goal as constraints")
    candidates = f"{config.max_duration_candidates} candidates"
    if config.max_extra_candidates:
        candidates += f" + up to {config.max_extra_candidates} more"
    parts.append(candidates)
    parts.append("PD + feed-forward" if block.feedforward else "PD")
    parts.append(f"after the arrival: {block.after_plan}")
    return ", ".join(parts)


def _finite(value):
    """A float, or None when it is not finite (strict JSON has no NaN)."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def planar_log(run: PlanarApproachRun, scenario, log: dict) -> dict:
    """The per-sample arrays the plug-in adds to log.npz (prefixed planar_; N samples):

    planar_plan_state (N, 6) the plan x(t) of eq. 1 at each sample (NaN outside [0, T]);
    planar_flown_state (N, 6) the truth's [x, y, theta, v_x, v_y, omega] in L (theta unwrapped);
    planar_position_error_m (N) |p - p_plan| (NaN outside [0, T]);
    planar_attitude_error_rad (N) theta - theta_ref wrapped, against the heading the tracker
    follows (the plan's, or with 'face_aligned' the turned one; NaN outside [0, T]);
    planar_target_yaw_rad (N) theta_t, unwrapped; planar_relative_velocity_T (N, 2) the chaser's
    velocity relative to the target, seen and expressed in T (Fig. 7): R(theta_t)^T (v -
    omega_t z x p); planar_p_T (N, 2) the chaser centre in T; planar_keepout_state (N) the KOS
    state (1 or 2) at the chaser's pose (State II needs the heading facing the docking face,
    rpod.models.planar_approach); planar_keepout_q_m (N) q of eq. 9 there (< 0 inside the
    zone); planar_goal_L (N, 2) x_goal; planar_chaser_side_m, planar_target_side_m (N).
    """
    config, plan = run.config, run.plan
    t = np.asarray(log["t"], float)
    n = len(t)
    R_IL = rotations_from_wxyz(log["q_IL"])
    R_LC = np.einsum("nji,njk->nik", R_IL, rotations_from_wxyz(log["q_IC"]))
    R_LT = np.einsum("nji,njk->nik", R_IL, rotations_from_wxyz(log["q_IT"]))
    theta = np.unwrap(np.arctan2(R_LC[:, 1, 0], R_LC[:, 0, 0]))
    # w_LC_L z = (R_LC w_IC_C) z - w_IL_L z (rpod.systems.planar_tracking).
    omega = np.einsum("nj,nj->n", R_LC[:, 2], log["w_IC_C"]) - log["w_IL_L"][:, 2]
    p, v = log["p_LC_L"][:, :2], log["v_LC_L"][:, :2]
    flown = np.column_stack([p, theta, v, omega])
    theta_t = np.unwrap(np.arctan2(R_LT[:, 1, 0], R_LT[:, 0, 0]))
    omega_t = np.einsum("nj,nj->n", R_LT[:, 2], log["w_IT_T"]) - log["w_IL_L"][:, 2]
    c, s = np.cos(theta_t), np.sin(theta_t)
    v_rel = v - omega_t[:, None] * np.column_stack([-p[:, 1], p[:, 0]])
    v_rel_T = np.column_stack(
        [c * v_rel[:, 0] + s * v_rel[:, 1], -s * v_rel[:, 0] + c * v_rel[:, 1]]
    )
    p_T = np.column_stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1]])
    heading_error = pa.face_heading_error(theta, theta_t)
    geometry = config.geometry
    planned = np.full((n, 6), np.nan)
    heading = np.full(n, np.nan)  # the tracked heading: the plan's, or turned to the face
    if plan.flyable:
        within = t <= plan.duration_s + 1e-9
        planned[within] = plan.x_traj.vector_values(t[within]).T
        heading[within] = run.reference.vector_values(t[within])[2]
    error = np.linalg.norm(p - planned[:, :2], axis=1)
    attitude = (theta - heading + math.pi) % (2.0 * math.pi) - math.pi
    return {
        "planar_plan_state": planned,
        "planar_flown_state": flown,
        "planar_position_error_m": error,
        "planar_attitude_error_rad": attitude,
        "planar_target_yaw_rad": theta_t,
        "planar_relative_velocity_T": v_rel_T,
        "planar_p_T": p_T,
        "planar_keepout_state": geometry.state(p_T, heading_error).astype(np.int64),
        "planar_keepout_q_m": geometry.q(p_T, heading_error),
        "planar_goal_L": np.tile(config.goal_position, (n, 1)),
        "planar_chaser_side_m": np.full(n, config.chaser_side_m),
        "planar_target_side_m": np.full(n, config.target_side_m),
    }


def switch_count(log: dict, scenario, period_s: float, until: int | None = None) -> int | None:
    """ON/OFF transitions of all thrusters up to sample `until` (the thrusters start OFF), or
    None when the log does not sample every PWM slot (module docstring)."""
    t = np.asarray(log["t"], float)
    end = len(t) if until is None else until + 1
    thrusters = scenario.thrusters
    slot = period_s / thrusters.subdivisions if thrusters.pwm else period_s
    if np.any(np.diff(t[:end]) > slot * (1.0 + 1e-6)):
        return None
    on = np.asarray(log["thruster_on"][:end]) > 0.5
    return int(np.count_nonzero(on[1:] != on[:-1]) + np.count_nonzero(on[:1]))


def plan_separation(run: PlanarApproachRun, scenario) -> tuple[float, float | None]:
    """(least separation of the true shapes along the plan [m], first planned time they touch
    or None), at the plan's knots, the target turning as the planner predicts it: whether a
    contact of the flown run was already in the plan. Exact: bounding spheres skip only the
    knots that cannot be nearer than the least exact separation found."""
    if not run.plan.flyable:
        return math.nan, None
    chaser_shape, target_shape = body_polytopes(scenario)
    reach = sum(float(np.max(np.linalg.norm(s.vertices, axis=1))) for s in body_polytopes(scenario))
    config, t, X = run.config, run.plan.t_knots, run.plan.x_knots
    theta_t = pa.target_attitude(t, config.theta_target0_rad, config.omega_target_rad_s)
    distance = np.linalg.norm(X[:, :2], axis=1) - reach  # a lower bound: bounding spheres
    # Exact where the bound is not above the least exact distance so far (nearest first), so
    # the minimum returned is exact, and every touching knot (bound <= 0) is evaluated.
    best = math.inf
    for k in np.argsort(distance):
        if distance[k] > 0.0 and distance[k] >= best:
            break
        distance[k] = separation_distance(
            target_shape,
            _rotation_z(theta_t[k]),
            np.zeros(3),
            chaser_shape,
            _rotation_z(X[k, 2]),
            np.array([X[k, 0], X[k, 1], 0.0]),
        )
        best = min(best, distance[k])
    touching = np.flatnonzero(distance <= 0.0)
    return float(max(np.min(distance), 0.0)), float(t[touching[0]]) if len(touching) else None


def _rotation_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _arrival_index(t: np.ndarray, arrival_s: float) -> int:
    """The first sample at or after the arrival (the last one if the run ended before)."""
    return int(min(np.searchsorted(t, arrival_s - 1e-9), len(t) - 1))


def planar_summary(run: PlanarApproachRun, scenario, log: dict, extra: dict) -> dict:
    """The summary.json entries (flat scalars prefixed planar_, for campaign reports)."""
    config, plan, block = run.config, run.plan, scenario.controller
    t = np.asarray(log["t"], float)
    # The approach: up to the arrival sample (the whole run without a plan); after it, the hold.
    # Contact counts over the whole run (the core's ContactWatch, summary["contact"]);
    # planar_contact_after_arrival_s says when a contact began in the hold.
    end = _arrival_index(t, plan.duration_s) if plan.flyable else len(t) - 1
    touching = np.flatnonzero(~(np.asarray(log["separation_m"], float) > 0.0))
    contact = bool(len(touching))
    after = touching[touching > end]
    q = extra["planar_keepout_q_m"][: end + 1]
    summary = {
        "planar_plan_status": plan.status.value,
        "planar_plan_success": bool(plan.success),
        "planar_plan_flown": bool(plan.flyable),
        "planar_plan_message": plan.solver_message,
        "planar_plan_duration_s": _finite(plan.duration_s),
        "planar_plan_cost": _finite(plan.cost),
        **{f"planar_plan_cost_{k}": _finite(v) for k, v in plan.cost_terms.items()},
        "planar_plan_solve_time_s": float(sum(c.solve_time_s for c in plan.candidates)),
        "planar_plan_candidates": [
            {
                "duration_s": c.duration_s,
                "status": c.status.value,
                "message": c.solver_message,
                "solve_time_s": c.solve_time_s,
                "iterations": c.iterations,
                "cost": _finite(c.cost),
            }
            for c in plan.candidates
        ],
        "planar_plan_check_passed": None if run.check is None else bool(run.check["passed"]),
        "planar_plan_terminal_position_error_m": _finite(plan.terminal_position_error_m),
        "planar_omega_target_rad_s": config.omega_target_rad_s,
        "planar_theta_approach_deg": math.degrees(config.theta_approach_rad),
        "planar_thrust_N": float(scenario.thrusters.max_thrust_N),
        "planar_modulation": scenario.thrusters.modulation,
        "planar_formulation": formulation_text(config, block),
        "planar_chaser_side_m": config.chaser_side_m,
        "planar_goal_L": config.goal_position.tolist(),
        "planar_contact": contact,
        "planar_first_contact_s": float(t[touching[0]]) if contact else None,
        "planar_min_keepout_q_m": float(np.min(q)),
        "planar_keepout_intrusion_s": float(np.sum(np.diff(t, append=t[-1])[: end + 1][q < 0.0])),
        "planar_contact_after_arrival_s": float(t[after[0]]) if len(after) else None,
        "planar_switches": switch_count(log, scenario, block.control_period_s),
        "planar_safe": bool(plan.success and not contact),  # whole run, goal reached by plan
    }
    plan_separation_m, plan_contact_s = plan_separation(run, scenario)
    summary["planar_plan_min_separation_m"] = _finite(plan_separation_m)
    summary["planar_plan_contact_s"] = plan_contact_s
    if run.check is not None:
        summary["planar_plan_terminal_relative_speed_m_s"] = run.check[
            "terminal_relative_speed_m_s"
        ]
        summary["planar_plan_min_keepout_q_m"] = run.check["keepout_q_m"]
    for key in ("rms_tracking_error_m", "max_tracking_error_m", "rms_attitude_error_deg"):
        summary[f"planar_{key}"] = None
    for key in ("position_error_m", "relative_speed_m_s", "attitude_error_deg", "time_s"):
        summary[f"planar_terminal_{key}"] = None
    summary.update(
        planar_delta_v_m_s=None,
        planar_plan_delta_v_m_s=None,
        planar_switches_to_arrival=None,
        planar_state_ii_from_s=None,
        planar_final_relative_speed_m_s=float(
            np.linalg.norm(extra["planar_relative_velocity_T"][-1])
        ),
        planar_final_hold_error_m=None,
        planar_hold_force_ratio=None,
        planar_after_plan=run.after_plan,
        planar_goal_reached=False,
    )
    if not plan.flyable:
        return summary
    T = float(plan.duration_s)
    i = _arrival_index(t, T)
    within = t <= T + 1e-9
    error = extra["planar_position_error_m"][within]
    attitude = extra["planar_attitude_error_rad"][within]
    p_i = log["p_LC_L"][i, :2]
    theta_i = extra["planar_flown_state"][i, 2]
    attitude_i = abs(float(pa.wrap_to_pi(theta_i - plan.theta_finish)))
    speed_i = float(np.linalg.norm(extra["planar_relative_velocity_T"][i]))
    position_i = float(np.linalg.norm(p_i - config.goal_position))
    mass = np.asarray(log["chaser_mass_kg"], float)
    isp = scenario.thrusters.isp_s
    dt_plan = np.diff(plan.t_knots)
    state_ii = np.flatnonzero(extra["planar_keepout_state"] == pa.STATE_II)
    summary.update(
        planar_rms_tracking_error_m=float(np.sqrt(np.mean(error**2))),
        planar_max_tracking_error_m=float(np.max(error)),
        planar_rms_attitude_error_deg=float(np.degrees(np.sqrt(np.mean(attitude**2)))),
        planar_terminal_time_s=float(t[i]),
        planar_terminal_position_error_m=position_i,
        planar_terminal_relative_speed_m_s=speed_i,
        planar_terminal_attitude_error_deg=math.degrees(attitude_i),
        planar_delta_v_m_s=float(STANDARD_GRAVITY_M_S2 * isp * math.log(mass[0] / mass[i])),
        planar_plan_delta_v_m_s=float(
            np.sum(np.linalg.norm(plan.wrench_knots[:, :2], axis=1) * dt_plan)
            / config.chaser_mass_kg
        ),
        planar_switches_to_arrival=switch_count(log, scenario, block.control_period_s, i),
        planar_state_ii_from_s=float(t[state_ii[0]]) if len(state_ii) else None,
    )
    summary["planar_hold_force_ratio"] = hold_force_ratio(plan, config)
    if run.after_plan == "co_rotate" and t[-1] > T:
        # The hold point: the plan's final position turned with the target since T.
        turn = config.omega_target_rad_s * (t[-1] - T)
        c, s = math.cos(turn), math.sin(turn)
        x_N = plan.x_knots[-1]
        hold = np.array([c * x_N[0] - s * x_N[1], s * x_N[0] + c * x_N[1]])
        summary["planar_final_hold_error_m"] = float(np.linalg.norm(log["p_LC_L"][-1, :2] - hold))
    summary["planar_goal_reached"] = bool(
        position_i <= block.goal_position_tolerance_m
        and speed_i <= block.goal_speed_tolerance_m_s
        and math.degrees(attitude_i) <= block.goal_attitude_tolerance_deg
    )
    return summary
