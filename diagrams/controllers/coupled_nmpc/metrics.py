"""Paper 001's coupled NMPC: what a run measured, from its log (numpy only, no plotting).

Owns: the mission's tolerances; the measures (`truth_relative_states`, `applied_forces`,
`constraint_excess`, `gimbal_face_angles`, `los_counted_outside`, `outside_summary`); the arrays
the plug-in adds to log.npz (`coupled_log`) and its summary.json entries (`coupled_summary`).
Does not own: the model (rpod.models.coupled_relative, rpod.models.gimbal), the controller and
its status codes (rpod.systems.coupled_nmpc_controller), the outcome line (mission.py) or the
figures (figures.py).

Thresholds: converged when the truth's eigenaxis error (eq. 5) is below ATTITUDE_TOLERANCE_DEG
(1 deg) and the feature points are within DISTANCE_TOLERANCE_M (0.1 m); `coupled_converged_at_s`
is the first log sample from which both hold at every later sample. A constraint excess: at
some log sample the applied forces leave a thruster's gimbal pyramid (eq. 16, from
rpod.models.gimbal.gimbal_polyhedron) or exceed f_max (eq. 17) by more than
CONSTRAINT_TOLERANCE_N (1e-6 N, round-off). The LOS polyhedron (eq. 18, soft in the paper) is
reported, not judged: the last sample outside it by more than LOS_TOLERANCE_M (1 mm), the
samples within DISTANCE_TOLERANCE_M of the rock left out (the pyramid's apex is the rock: there
the margin is a fraction of a distance already below the tolerance), and the least margin after
it (outside that ball).

Applied forces. The bank's clipped forces are not an output port of ThrusterBank; they are
recomputed here from the logged command (`thruster_force_C`) by the bank's own rule
(rpod.models.gimbal.GimbalLimits.clip, which the bank calls), and checked against the bank's
own logged output: the resultant wrench of the recomputed forces must equal `body_wrench`
(`coupled_applied_wrench_mismatch`, ~1e-13 N). On a fixed bank the applied force of thruster k
is its logged level (`thruster_on`, after the PWM) times f_max along its nozzle: no gimbal, so
the gimbal excess is 0 and the magnitude excess |f_k| - f_max.

Gimbal angle (`gimbal_face_angles`): the pyramid of eq. 16 bounds |f.e| <= tan(alpha) f.n
separately for its two lateral axes e in {i_K, k_K} (n the nominal direction), so its limit is
alpha on each face while a corner lies atan(sqrt(2) tan(alpha)) = 54.7 deg (alpha = 45 deg) off
n. The largest face-angle phi_k = max_e atan2(|f.e|, f.n) is the angle of f off n in the plane
of (n, e): for f != 0, phi_k <= alpha exactly when A_k f <= 0 (every row).
"""

import math

import numpy as np

from rpod.diagrams.controllers.coupled_nmpc.problem import planning_frame_R_CCp
from rpod.diagrams.scenario import make_thruster_layout
from rpod.models import coupled_relative as cr
from rpod.models.frames import lvlh_to_inertial, rotations_from_wxyz
from rpod.models.gimbal import (
    GimbalLimits,
    gimbal_polyhedron,
    thruster_frame_C,
    wrench_from_forces,
)
from rpod.models.thrusters import ThrusterLayout
from rpod.systems.coupled_nmpc_controller import STATUS_SIZE, NmpcFallback

ATTITUDE_TOLERANCE_DEG = 1.0
DISTANCE_TOLERANCE_M = 0.1
CONSTRAINT_TOLERANCE_N = 1e-6
LOS_TOLERANCE_M = 1e-3
STATUS_LOG_KEY = "coupled_nmpc_status_vector"  # the raw (n, 5) log, split by coupled_log


def los_counted_outside(margin_m: np.ndarray, distance_m: np.ndarray) -> np.ndarray:
    """The samples counted outside the LOS pyramid (eq. 18): more than LOS_TOLERANCE_M out, and
    not within DISTANCE_TOLERANCE_M of the rock (there the pyramid's apex is mm away and its
    margin is noise). The outcome line and coupled_nmpc.png both count these."""
    return (np.asarray(margin_m) < -LOS_TOLERANCE_M) & (
        np.asarray(distance_m) >= DISTANCE_TOLERANCE_M
    )


def truth_relative_states(
    params: cr.CoupledRelativeParams, log: dict, R_CCp: np.ndarray | None = None
) -> np.ndarray:
    """x (n, 39) of the truth at every log sample, by cr.relative_state_from_absolute.

    The chaser is placed relative to the target (p_IT_I = 0 in the call, p_TC_I from the
    logged relative state), so no 7,000 km coordinates are subtracted; x[:, 21:] is then not
    the target's orbit (not used here). R_CCp: the planner's chaser frame C' (problem.py), in
    which params are given and R_TC' is measured; None: C itself.
    """
    R_IT = rotations_from_wxyz(log["q_IT"])
    R_IC = rotations_from_wxyz(log["q_IC"])
    R_IL = rotations_from_wxyz(log["q_IL"])
    w_IC_C = np.asarray(log["w_IC_C"], dtype=float)
    if R_CCp is not None:
        R_IC, w_IC_C = R_IC @ R_CCp, w_IC_C @ R_CCp
    zero = np.zeros(3)
    states = np.empty((len(log["t"]), cr.STATE_SIZE))
    for i in range(len(states)):
        p_TC_I, v_TC_I = lvlh_to_inertial(
            R_IL[i], log["w_IL_L"][i], log["p_LC_L"][i], log["v_LC_L"][i]
        )
        states[i] = cr.relative_state_from_absolute(
            params, R_IT[i], log["w_IT_T"][i], zero, zero, R_IC[i], w_IC_C[i], p_TC_I, v_TC_I
        )
    return states


def applied_forces(layout: ThrusterLayout, commanded: np.ndarray) -> np.ndarray:
    """The forces the bank applies (n, 24) for logged commands (n, 24), by its own clip."""
    limits = GimbalLimits(layout)
    forces = np.empty_like(commanded, dtype=float)
    for i, command in enumerate(commanded):
        clipped, _ = limits.clip(np.asarray(command, dtype=float).reshape(layout.count, 3))
        forces[i] = clipped.ravel()
    return forces


def constraint_excess(layout: ThrusterLayout, forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(gimbal excess, magnitude excess) (n,) [N] of forces (n, 24): the largest A_k f_k - b_k
    over thrusters (eq. 16, gimbal_polyhedron) and the largest |f_k| - f_max (eq. 17)."""
    F = forces.reshape(len(forces), layout.count, 3)
    gimbal = np.full(len(forces), -np.inf)
    for k, thruster in enumerate(layout.thrusters):
        A, b = gimbal_polyhedron(thruster)
        gimbal = np.maximum(gimbal, np.max(F[:, k] @ A.T - b, axis=1))
    magnitude = np.max(np.linalg.norm(F, axis=2) - layout.max_thrusts_N, axis=1)
    return gimbal, magnitude


def _converged_at(t: np.ndarray, ok: np.ndarray) -> float | None:
    """The first sample from which ok holds to the end (None when not at the end)."""
    if not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    return float(t[bad[-1] + 1]) if len(bad) else float(t[0])


def gimbal_face_angles(
    layout: ThrusterLayout, f_K_C: np.ndarray, min_force_N: float = 0.0
) -> np.ndarray:
    """The largest face-angle of each thruster's force in its gimbal pyramid (eq. 16) [rad].

    phi_k = max over e in {i_K, k_K} of atan2(|f_k . e|, f_k . n_k), n_k the nominal direction
    (`layout.directions_C[k]`), i_K and k_K the lateral axes of `thruster_frame_C` (the axes of
    `gimbal_polyhedron`'s faces). For f_k != 0, phi_k <= alpha_k exactly when A_k f_k <= 0:
    0 along n_k, alpha_k on a face (and on an edge of the pyramid), above alpha_k outside,
    pi / 2 or more for a force that does not point along n_k at all (module docstring).

    Args:
        layout: The thrusters (positions unused).
        f_K_C: Forces on the chaser in C, (N, 3 n) stacked thruster by thruster, (N, n, 3), or
            one sample (3 n,) or (n, 3) [N].
        min_force_N: Forces with |f_k| <= this give NaN (no meaningful direction); a zero force
            always does.

    Returns:
        (N, n) angles [rad] in [0, pi], or (n,) for one sample.
    """
    F = np.asarray(f_K_C, dtype=float)
    single = F.ndim == 1 or (F.ndim == 2 and F.shape == (layout.count, 3))
    F = F.reshape(-1, layout.count, 3)
    n = layout.directions_C  # (n, 3)
    frames = np.stack([thruster_frame_C(thruster) for thruster in layout.thrusters])
    along = np.einsum("tkj,kj->tk", F, n)
    lateral_i = np.einsum("tkj,kj->tk", F, frames[:, :, 0])  # i_K, the first column
    lateral_k = np.einsum("tkj,kj->tk", F, frames[:, :, 2])  # k_K, the third column
    phi = np.maximum(
        np.arctan2(np.abs(lateral_i), along),  # face pair +-i_K of eq. 16
        np.arctan2(np.abs(lateral_k), along),  # face pair +-k_K of eq. 16
    )
    magnitude = np.linalg.norm(F, axis=2)
    phi = np.where((magnitude > min_force_N) & (magnitude > 0.0), phi, np.nan)
    return phi[0] if single else phi


def outside_summary(t: np.ndarray, margin: np.ndarray) -> tuple[float, float, float | None]:
    """(time outside [s], deepest [m], last exit [s] or None) of a margin (< 0 outside).

    Sample i is held over [t_i, t_{i+1}) (the last one as long as the one before); the last exit
    is the time of the first sample inside after the last one outside (None when the run ends
    outside or never was outside).
    """
    outside = margin < 0.0
    if not outside.any():
        return 0.0, 0.0, None
    dt = np.diff(t)
    held = np.r_[dt, dt[-1:]] if len(dt) else np.zeros(1)
    last = int(np.flatnonzero(outside)[-1])
    exit_s = float(t[last + 1]) if last + 1 < len(t) else None
    return float(held[outside].sum()), float(-margin[outside].min()), exit_s


def coupled_log(scenario, params: cr.CoupledRelativeParams, log: dict):
    """(arrays added to log.npz, gimbal excess, magnitude excess, applied wrench) of a run: the
    truth's relative state, the applied forces and their limits, the LOS margin and the NMPC's
    status split (figures.py documents each key); `log` is read, never changed."""
    config = scenario.controller
    truth_layout = make_thruster_layout(scenario)  # the bank's limits, not the plan's
    t = log["t"]
    n = len(t)
    out = {}

    # The truth's relative state (eqs. 3-8) and the eigenaxis error (eq. 5).
    x = truth_relative_states(params, log, planning_frame_R_CCp(scenario))
    R_TC = x[:, cr.R_TC_SLICE].reshape(n, 3, 3)
    out["coupled_eigenaxis_error_rad"] = np.array([cr.eigenaxis_error(R) for R in R_TC])
    out["coupled_w_TC_T_rad_s"] = x[:, cr.W_TC_T_SLICE]
    out["coupled_p_PtPc_T_m"] = x[:, cr.P_PTPC_T_SLICE]
    out["coupled_v_PtPc_T_m_s"] = x[:, cr.V_PTPC_T_SLICE]

    # The forces the bank applied, their wrench, and the limits measured on them.
    if truth_layout.gimbaled:
        commanded = log.get("thruster_force_C", np.zeros((n, 3 * truth_layout.count)))
        forces = applied_forces(truth_layout, commanded)
        gimbal, magnitude = constraint_excess(truth_layout, forces)
    else:  # a fixed bank (module docstring)
        on = np.clip(log.get("thruster_on", np.zeros((n, truth_layout.count))), 0.0, 1.0)
        thrust = on * truth_layout.max_thrusts_N
        forces = (thrust[:, :, None] * truth_layout.directions_C[None]).reshape(n, -1)
        gimbal = np.zeros(n)
        magnitude = np.max(thrust - truth_layout.max_thrusts_N, axis=1)
    wrench = np.array([wrench_from_forces(truth_layout, f) for f in forces])
    out["coupled_thruster_forces_C_N"] = forces
    out["coupled_torque_C_Nm"] = wrench[:, :3]  # eq. 12
    out["coupled_force_C_N"] = wrench[:, 3:]  # eq. 11
    out["coupled_max_thrust_N"] = np.full(n, float(np.max(truth_layout.max_thrusts_N)))
    out["coupled_gimbal_half_angle_rad"] = np.full(
        n, float(np.max(truth_layout.gimbal_half_angles_rad))
    )

    # The LOS polyhedron (eq. 18): margin > 0 inside.
    half_angle = config.nmpc.los_half_angle_rad
    A_p = cr.los_polyhedron(params.p_TPt_T, half_angle)
    out["coupled_los_margin_m"] = -np.max(out["coupled_p_PtPc_T_m"] @ A_p.T, axis=1)
    out["coupled_target_feature_point_T_m"] = np.tile(params.p_TPt_T, (n, 1))
    out["coupled_los_half_angle_rad"] = np.full(n, half_angle)

    # The controller's status, sampled.
    status = log.get(STATUS_LOG_KEY, np.full((n, STATUS_SIZE), np.nan))
    out[STATUS_LOG_KEY] = None  # split below, not kept
    out["nmpc_status"] = status[:, 0].astype(np.int64)
    out["nmpc_fallback"] = status[:, 1].astype(np.int64)
    out["nmpc_iterations"] = status[:, 2].astype(np.int64)
    out["nmpc_solve_time_s"] = status[:, 3]
    out["nmpc_cost"] = status[:, 4]
    return out, gimbal, magnitude, wrench


def coupled_summary(records, log: dict, out: dict, gimbal, magnitude, wrench) -> dict:
    """summary.json's entries (module docstring) from `coupled_log`'s results and the
    controller's solve records (rpod.systems.coupled_nmpc_controller.SolveRecord)."""
    t = log["t"]
    error_deg = np.degrees(out["coupled_eigenaxis_error_rad"])
    distance = np.linalg.norm(out["coupled_p_PtPc_T_m"], axis=1)
    speed = np.linalg.norm(out["coupled_v_PtPc_T_m_s"], axis=1)
    ok = (error_deg < ATTITUDE_TOLERANCE_DEG) & (distance < DISTANCE_TOLERANCE_M)
    converged_at = _converged_at(t, ok)
    margin = out["coupled_los_margin_m"]
    outside = np.flatnonzero(los_counted_outside(margin, distance))
    last_violation = float(t[outside[-1]]) if len(outside) else None
    start = outside[-1] + 1 if len(outside) else 0
    after = margin[start:][distance[start:] >= DISTANCE_TOLERANCE_M]
    mismatch = float(np.max(np.abs(wrench - log["body_wrench"]))) if "body_wrench" in log else None

    times = np.array([r.solve_time_s for r in records if math.isfinite(r.solve_time_s)])
    by_status, failed_by_status, messages = {}, {}, {}
    for record in records:
        by_status[record.status] = by_status.get(record.status, 0) + 1
        if not record.usable:
            failed_by_status[record.status] = failed_by_status.get(record.status, 0) + 1
            messages[record.message] = messages.get(record.message, 0) + 1
    fallbacks = [r.fallback for r in records]

    def stat(fn):
        return float(fn(times)) if len(times) else None

    return {
        "coupled_final_eigenaxis_error_deg": float(error_deg[-1]),
        "coupled_final_distance_m": float(distance[-1]),
        "coupled_final_speed_m_s": float(speed[-1]),
        "coupled_converged": converged_at is not None,
        "coupled_converged_at_s": converged_at,
        "coupled_max_gimbal_excess_N": float(np.max(gimbal)),
        "coupled_max_magnitude_excess_N": float(np.max(magnitude)),
        "coupled_constraint_excess": bool(
            max(np.max(gimbal), np.max(magnitude)) > CONSTRAINT_TOLERANCE_N
        ),
        "coupled_applied_wrench_mismatch": mismatch,
        "coupled_los_last_violation_s": last_violation,
        "coupled_los_violation_samples": len(outside),
        "coupled_los_violated_at_end": bool(len(outside) and outside[-1] == len(t) - 1),
        "coupled_los_min_margin_after_m": float(np.min(after)) if len(after) else None,
        "nmpc_solves": len(records),
        "nmpc_solves_by_status": by_status,
        "nmpc_not_usable": sum(1 for r in records if not r.usable),
        "nmpc_not_usable_by_status": failed_by_status,
        "nmpc_failure_messages": messages,
        "nmpc_fallback_steps": sum(1 for f in fallbacks if f != NmpcFallback.NONE),
        "nmpc_fallback_previous_plan": fallbacks.count(NmpcFallback.PREVIOUS_PLAN),
        "nmpc_fallback_zero_thrust": fallbacks.count(NmpcFallback.ZERO_THRUST),
        "nmpc_solve_time_s_median": stat(np.median),
        "nmpc_solve_time_s_p95": stat(lambda v: np.percentile(v, 95)),
        "nmpc_solve_time_s_max": stat(np.max),
    }
