"""An independent checker of paper 003's approach plans (eqs. 6-9 evaluated on the result).

Owns: `check_plan` and its pass thresholds `CHECK_TOLERANCES`: every constraint of eqs. 6-9
re-evaluated on a `PlanarPlan`'s trajectories through code paths separate from the planner's
(the eq. 7 residual and an exact zero-order-hold re-integration written out here, the body
wrench against the limits and the planar_8 allocation, the KOS with the exact shapes at 10
points per step, the true squares' overlap by separating axes, the terminal errors; details in
`check_plan`). It reports the worst values and whether they pass; it does not decide what a plan
is for. Does not own: planning, or any program. It imports no planner module at run time (the
config and plan types for annotations only): the KOS comes from rpod.models.planar_approach and
the allocation from rpod.models.thrusters.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from rpod.models import planar_approach as pa
from rpod.models.thrusters import allocate_duty, planar_8, wrench_matrix

if TYPE_CHECKING:  # annotations only: the checker runs none of the planner's code
    from rpod.planners.planar_approach import PlanarApproachConfig, PlanarPlan

_CHECK_SAMPLES_PER_STEP = 10
"""The checker evaluates the KOS at this many points per step (10x the knot density)."""


CHECK_TOLERANCES = {
    "euler_residual": 1e-6,  # m, rad, m/s, rad/s: Clarabel's equality rows (~1e-9) with margin
    "initial_state_error": 1e-9,
    "final_attitude_error_rad": 1e-6,
    "arrival_attitude_error_rad": 1e-9,  # N dt = T exactly
    "force_excess_N": 1e-6,
    "torque_excess_Nm": 1e-7,
    "wrench_cut_excess_N": 1e-6,
    "allocation_residual": 1e-6,  # planar_8 reproduces the wrench (eq. 14 at zero residual)
    "keepout_q_m": -1e-9,  # a lower bound: q >= 0 everywhere (polygons are circumscribed)
    "squares_gap_m": 0.0,  # a lower bound: the true squares never overlap (strictly > 0)
}
"""Pass thresholds of `check_plan` (upper bounds except keepout_q_m, a lower bound)."""


def _wrap(angle: float) -> float:
    return float((angle + math.pi) % (2.0 * math.pi) - math.pi)


def check_plan(plan: PlanarPlan, config: PlanarApproachConfig) -> dict:
    """Re-evaluates every constraint of eqs. 6-9 on a plan, independently of the planner.

    Reads the plan's trajectories (x_traj, wrench_traj), not its knot arrays, and recomputes:
    the eq. 7 residual per step (written out here); an exact zero-order-hold re-integration of
    eq. 2 from x_0 under the planned wrench (closed form, written out here; it differs from the
    plan by eq. 7's dropped a dt^2 / 2 terms: information, not a pass criterion); x_0 and the
    final attitude (mod 2 pi) against the request; the target attitude at arrival; the body
    wrench against the limits and, by rpod.models.thrusters.allocate_duty, whether the planar_8
    layout that has these limits reproduces it; the KOS q in the paper's switching state at
    10 points per step (the straight segments of eq. 7, the target at each point's own time,
    the heading interpolated as the plan's first-order hold: State II needs it aligned) with
    the exact shapes (not the planner's polygons); whether the true squares overlap there
    (separating axes, written out here); the terminal errors, the terminal relative velocity
    of (5') among them.

    Returns:
        A dict of worst values (names as in CHECK_TOLERANCES, plus information entries) and
        "passed": every CHECK_TOLERANCES entry holds (squares_gap_m strictly above 0).
    """
    if plan.x_traj is None or plan.wrench_traj is None:
        return {"passed": False, "reason": f"no plan ({plan.status.value})"}
    m, inertia = config.chaser_mass_kg, config.chaser_inertia_kg_m2
    t = np.asarray(plan.t_knots, dtype=float)
    dt = np.diff(t)
    X = plan.x_traj.vector_values(t).T
    F = plan.wrench_traj.vector_values(t[:-1]).T
    acc = F / np.array([m, m, inertia])
    # Eq. 7.
    predicted = X[:-1] + dt[:, None] * np.column_stack([X[:-1, 3:], acc])
    euler = float(np.abs(X[1:] - predicted).max())
    # Exact ZOH re-integration of eq. 2 from x_0.
    q, v = X[0, :3].copy(), X[0, 3:].copy()
    drift = np.zeros(3)
    drift_v = 0.0
    for k in range(len(dt)):
        q = q + v * dt[k] + 0.5 * acc[k] * dt[k] ** 2
        v = v + acc[k] * dt[k]
        drift = np.maximum(drift, np.abs(q - X[k + 1, :3]))
        drift_v = max(drift_v, float(np.abs(v - X[k + 1, 3:]).max()))
    # Eq. 6 and the arrival attitude.
    T = float(t[-1])
    final_attitude = abs(_wrap(X[-1, 2] - config.theta_approach_rad - math.pi))
    arrival = abs(
        _wrap(config.theta_target0_rad + config.omega_target_rad_s * T - config.theta_approach_rad)
    )
    # Eq. 8 in the body frame.
    c, s = np.cos(X[:-1, 2]), np.sin(X[:-1, 2])
    fbx = c * F[:, 0] + s * F[:, 1]
    fby = -s * F[:, 0] + c * F[:, 1]
    tau = F[:, 2]
    fmax, tmax = config.max_force_N, config.max_torque_Nm
    force_excess = float(np.maximum(np.abs(fbx), np.abs(fby)).max() - fmax)
    torque_excess = float(np.abs(tau).max() - tmax)
    cut = np.abs(fbx) + np.abs(fby) + 2.0 * fmax / tmax * np.abs(tau) - 2.0 * fmax
    layout = planar_8(side_m=tmax / fmax, max_thrust_N=0.5 * fmax)
    B = wrench_matrix(layout)
    allocation = 0.0
    for k in range(len(tau)):
        w = np.array([0.0, 0.0, tau[k], fbx[k], fby[k], 0.0])
        allocation = max(allocation, float(np.abs(B @ allocate_duty(B, w) - w).max()))
    # Eq. 9 at 10 points per step.
    n = _CHECK_SAMPLES_PER_STEP
    ts = np.append((t[:-1, None] + np.arange(n)[None, :] / n * dt[:, None]).ravel(), T)
    x_s = plan.x_traj.vector_values(ts)
    p = x_s[:2].T
    theta_t = config.theta_target0_rad + config.omega_target_rad_s * ts
    ct, st = np.cos(theta_t), np.sin(theta_t)
    p_T = np.column_stack([ct * p[:, 0] + st * p[:, 1], -st * p[:, 0] + ct * p[:, 1]])
    heading = (x_s[2] - theta_t) % (2.0 * math.pi) - math.pi  # wrap(theta - theta_t - pi)
    switch_heading = heading if config.state_ii_heading else None  # the plan's formulation
    q_values = config.geometry.q(p_T, switch_heading)
    state = config.geometry.state(p_T, switch_heading)
    # The true squares at the same points (separating axes: the two squares' edge normals).
    phi = x_s[2] - theta_t
    half_c, half_t = 0.5 * config.chaser_side_m, 0.5 * config.target_side_m
    gaps = []
    for axis in (0.0, 0.5 * math.pi):  # the target's axes
        u = np.array([math.cos(axis), math.sin(axis)])
        reach = half_c * (np.abs(np.cos(phi - axis)) + np.abs(np.sin(phi - axis)))
        gaps.append(np.abs(p_T @ u) - half_t - reach)
    for offset in (0.0, 0.5 * math.pi):  # the chaser's axes, in T
        u = np.column_stack([np.cos(phi + offset), np.sin(phi + offset)])
        reach = half_t * (np.abs(u[:, 0]) + np.abs(u[:, 1]))
        gaps.append(np.abs(np.sum(p_T * u, axis=1)) - half_c - reach)
    gap = np.max(gaps, axis=0)
    goal = config.standoff_m * np.array(
        [math.cos(config.theta_approach_rad), math.sin(config.theta_approach_rad)]
    )
    p_N, v_N = X[-1, :2], X[-1, 3:5]
    relative_v = v_N - config.omega_target_rad_s * np.array([-p_N[1], p_N[0]])
    report = {
        "euler_residual": euler,
        "initial_state_error": float(np.abs(X[0] - plan.x0).max()),
        "final_attitude_error_rad": final_attitude,
        "arrival_attitude_error_rad": arrival,
        "force_excess_N": force_excess,
        "torque_excess_Nm": torque_excess,
        "wrench_cut_excess_N": float(cut.max()) if config.wrench_limit == "planar_8" else 0.0,
        "allocation_residual": allocation if config.wrench_limit == "planar_8" else 0.0,
        "keepout_q_m": float(q_values.min()),
        "squares_gap_m": float(gap.min()),
        "keepout_violations": int(np.sum(q_values < CHECK_TOLERANCES["keepout_q_m"])),
        "keepout_samples": len(ts),
        "zoh_drift_position_m": float(drift[:2].max()),
        "zoh_drift_attitude_rad": float(drift[2]),
        "zoh_drift_velocity": drift_v,
        "terminal_position_error_m": float(np.linalg.norm(p_N - goal)),
        "terminal_speed_m_s": float(np.linalg.norm(v_N)),
        "terminal_relative_speed_m_s": float(np.linalg.norm(relative_v)),
        "state_ii_fraction": float(np.mean(state == pa.STATE_II)),
        "state_ii_max_heading_error_rad": float(
            np.abs(heading[state == pa.STATE_II]).max() if np.any(state == pa.STATE_II) else 0.0
        ),
    }
    lower_bounds = ("keepout_q_m", "squares_gap_m")
    passed = all(
        report[name] >= bound if name in lower_bounds else report[name] <= bound
        for name, bound in CHECK_TOLERANCES.items()
    )
    passed = passed and report["squares_gap_m"] > 0.0
    report["passed"] = bool(passed)
    return report
