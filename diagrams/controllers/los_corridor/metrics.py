"""Paper 004's guidance: a run's results, from its log (numpy only, no plotting).

Owns: `violation_summary` (the depth, time in violation and first time of a corridor
violation, for any code that reports on the corridor: these results and figures.py),
`applied_acceleration_L`, and `los_results`: the arrays the plug-in adds to log.npz, its
summary.json entries (violations, regimes, the MPC's statuses and fallbacks, the steps without
a usable input by the hard QP's status: `no_input_by_status`) and the mission outcome.
Does not own: the corridor (rpod.models.los_corridor), the guidance and its status codes
(rpod.systems.los_guidance), the figures (figures.py) or the campaign tables (tables.py).

Mission (paper 004 Sec. 9's classification): success is zero corridor violations beyond
VIOLATION_TOLERANCE_M (1e-3 m, at every log sample) AND the hold point held at the end (the
hold regime at the last control step). An infeasible QP is logged and counted; it fails the
mission only through what it leads to (a violation, or no hold).

Violation: a sample whose least distance over the n_f + 1 planes is below -tol, tol = 1e-3 m
(paper 004 Sec. 9's classification tolerance). Sample i is held over [t_i, t_{i+1}); the last
sample lasts as long as the one before (a single sample: 0 s).
"""

import math

import numpy as np

from rpod.diagrams.controller_seam import MissionOutcome
from rpod.diagrams.target_frame import chaser_in_target_frame
from rpod.models.frames import rotations_from_wxyz
from rpod.models.los_corridor import VIOLATION_TOLERANCE_M, sync_range_m
from rpod.planners.los_corridor_mpc import MpcStatus
from rpod.systems.los_guidance import MPC_STATUS_CODES, Fallback, Regime

STATUS_LOG_KEY = "los_guidance_status"  # the raw (n, 5) log, split by los_results


def violation_summary(
    t: np.ndarray, distance: np.ndarray, tol: float = VIOLATION_TOLERANCE_M
) -> tuple[float, float, float | None]:
    """The worst depth, the time in violation and the first violating time of a corridor.

    A sample violates when its least distance (over the columns of a 2-D `distance`) is below
    -tol; NaN distances never violate. Sample i counts for t_{i+1} - t_i, the last one for the
    interval before it (a single sample for 0).

    Args:
        t: Sample times (N,) [s].
        distance: Signed distance to each constraint, positive inside, (N,) or (N, m) [m].
        tol: Tolerance [m] (>= 0): a distance of exactly -tol is not a violation.

    Returns:
        (depth_m, duration_s, first_s): the largest -distance over the violating samples (0.0
        when none), their summed durations (0.0 when none), and the time of the first one
        (None when none).
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    d = np.asarray(distance, dtype=float)
    if d.ndim == 2:
        d = np.fmin.reduce(d, axis=1) if d.shape[1] else np.full(len(d), np.nan)  # NaN-skipping
    if d.shape != t.shape:
        raise ValueError(f"distance has {d.shape[0]} samples, t has {t.shape[0]}")
    violating = d < -tol
    if not violating.any():
        return 0.0, 0.0, None
    dt = np.diff(t)
    held = np.r_[dt, dt[-1:]] if len(dt) else np.zeros(1)
    return float(-d[violating].min()), float(held[violating].sum()), float(t[violating][0])


def applied_acceleration_L(log: dict) -> np.ndarray:
    """The acceleration the truth received, in L: R_LI R_IC f_C / m (N, 3) [m/s^2]."""
    R_IC = rotations_from_wxyz(log["q_IC"])
    R_IL = rotations_from_wxyz(log["q_IL"])
    f_I = np.einsum("nij,nj->ni", R_IC, log["body_wrench"][:, 3:6])
    return np.einsum("nji,nj->ni", R_IL, f_I) / log["chaser_mass_kg"][:, None]


def _control_step_samples(t: np.ndarray, period_s: float) -> np.ndarray:
    """The indices of the log samples nearest each control step k period_s (unique)."""
    steps = np.arange(0.0, t[-1] + 0.5 * period_s, period_s)
    index = np.clip(np.searchsorted(t, steps - 1e-9), 0, len(t) - 1)
    return np.unique(index)


def _solver_text(summary: dict) -> str:
    """How the filter fared: unsolved QPs and the steps each fallback flew (README promise)."""
    text = f"{summary['los_qp_not_solved']} QPs not solved, {summary['los_fallback_steps']} steps on a fallback"
    if summary["los_fallback_steps"]:
        kinds = [
            ("best-effort QP", summary["los_fallback_best_effort"]),
            ("previous plan", summary["los_fallback_previous_plan"]),
            ("brake", summary["los_fallback_brake"]),
            ("far command", summary["los_fallback_far_command"]),
        ]
        text += " (" + ", ".join(f"{name} {count}" for name, count in kinds if count) + ")"
    return text


def _sync_range_m(scenario) -> float:
    """r_sync = 2 a_max / omega_t^2 (eq. 14) of the scenario's spin, inf without one."""
    omega = float(np.linalg.norm(np.radians(scenario.target.w_IT_T_deg_s)))
    return sync_range_m(scenario.controller.a_max_m_s2, omega) if omega > 0 else math.inf


def no_input_by_status(codes: np.ndarray, fallbacks: np.ndarray, regimes: np.ndarray) -> dict:
    """The steps without a usable input (`solver_failures`: the previous plan or the brake
    flew) counted by what the hard QP said at that step: an MpcStatus value, or `skipped`
    (beyond one step of the corridor the hard QP is not tried: skip_hard_qp_outside), each
    split into the far regime (`far_...`: no best-effort QP there, by design) and the others
    (where the best-effort QP was tried too and also gave nothing). `primal_infeasible` is the
    solver's certificate that no input keeps the corridor; `max_iterations` and `other` leave
    open whether one existed. Fixed keys, so a campaign table has one column each."""
    names = {code: status.value for status, code in MPC_STATUS_CODES.items()}
    no_input = (fallbacks == Fallback.PREVIOUS_PLAN) | (fallbacks == Fallback.BRAKE)
    counts = {}
    for far in (True, False):
        in_regime = no_input & ((regimes == Regime.FAR) == far)
        for code, name in [*names.items(), (-1, "skipped")]:
            key = ("far_" if far else "") + name
            counts[key] = int(np.count_nonzero(in_regime & (codes == code)))
    return counts


def los_log(scenario, p_TH_T: np.ndarray, log: dict, R_TK=None) -> dict:
    """The arrays added to log.npz (figures.py documents each): the raw status vector split
    (and removed: None), the range in T, the constant levels, the applied acceleration, and
    with a corridor about another axis than +y_T its frame (R_TK, row-major, per sample)."""
    config = scenario.controller
    status = log[STATUS_LOG_KEY]
    n = len(log["t"])
    out = {STATUS_LOG_KEY: None}  # split below, not kept
    out["los_regime"] = status[:, 0].astype(np.int64)
    out["los_mpc_status"] = status[:, 1].astype(np.int64)
    out["los_fallback"] = status[:, 2].astype(np.int64)
    out["los_mpc_iterations"] = status[:, 3].astype(np.int64)
    out["los_mpc_solve_time_s"] = status[:, 4]
    p_T = chaser_in_target_frame(log["q_IT"], log["q_IL"], log["p_LC_L"])
    out["los_range_m"] = np.linalg.norm(p_T, axis=1)
    out["los_sync_range_m"] = np.full(n, _sync_range_m(scenario))
    out["los_hold_point_T"] = np.tile(p_TH_T, (n, 1))
    out["los_a_max_m_s2"] = np.full(n, config.a_max_m_s2)
    out["los_half_angle_deg"] = np.full(n, config.half_angle_deg)
    out["los_applied_L"] = applied_acceleration_L(log)
    if R_TK is not None:
        out["los_R_TK"] = np.tile(np.asarray(R_TK, dtype=float).reshape(9), (n, 1))
    return out


def los_results(
    scenario, p_TH_T: np.ndarray, log: dict, R_TK=None
) -> tuple[dict, dict, MissionOutcome]:
    """(log additions, summary.json's entries, mission outcome) of a finished run (module
    docstring); `log` is read, never changed."""
    config = scenario.controller
    out = los_log(scenario, p_TH_T, log, R_TK)
    t = log["t"]
    regime = out["los_regime"]
    p_T = chaser_in_target_frame(log["q_IT"], log["q_IL"], log["p_LC_L"])
    r_sync = _sync_range_m(scenario)
    depth, duration, first = violation_summary(t, log["los_face_distance_m"], VIOLATION_TOLERANCE_M)
    # One sample per control step: the samples at k period_s hold step k - 1's status
    # (the t = 0 sample holds the initial -1s, left out of the counts).
    steps = _control_step_samples(t, config.control_period_s)
    steps = steps[regime[steps] >= 0]
    codes = out["los_mpc_status"][steps]
    # OSQP's verdict other than 'solved' (an unfinished iterate may still have passed the
    # rollout check and flown), and the steps flown on a fallback.
    not_solved = int(np.count_nonzero((codes >= 0) & (codes != MPC_STATUS_CODES[MpcStatus.SOLVED])))
    fallbacks = out["los_fallback"][steps]
    on_fallback = int(np.count_nonzero(fallbacks != Fallback.NONE))
    hold_distance = float(np.linalg.norm(p_T[-1] - p_TH_T))
    held = bool(regime[-1] == Regime.HOLD)
    # The hold reached: the first sample of the final run of hold samples.
    not_holding = np.flatnonzero(regime != Regime.HOLD)
    reached = int(not_holding[-1]) + 1 if len(not_holding) else 0
    min_distance = float(np.nanmin(log["los_face_distance_m"]))
    summary = {
        "los_sync_range_m": r_sync,
        "los_start_inside_sync_range": bool(out["los_range_m"][0] <= r_sync),
        "los_violation": depth > 0,
        "los_violation_depth_m": depth,
        "los_violation_duration_s": duration,
        "los_first_violation_s": first,
        "los_min_face_distance_m": min_distance,
        "los_min_range_m": float(np.min(out["los_range_m"])),
        "los_held": held,
        "los_hold_reached_s": float(t[reached]) if held else None,
        "los_final_hold_error_m": hold_distance,
        "los_qp_not_solved": not_solved,
        "los_fallback_steps": on_fallback,
        # The seam's names for every method (rpod.diagrams.controller_seam.ControllerResults):
        # steps that no QP gave an input where one was due (the hard QP's failure outside the
        # corridor is answered by the best-effort QP, and far out by the far command, as
        # designed: those are fallbacks, not failures), and the time on any fallback.
        "solver_failures": int(
            np.count_nonzero((fallbacks == Fallback.PREVIOUS_PLAN) | (fallbacks == Fallback.BRAKE))
        ),
        "fallback_s": on_fallback * config.control_period_s,
        "los_fallback_previous_plan": int(np.count_nonzero(fallbacks == Fallback.PREVIOUS_PLAN)),
        "los_fallback_brake": int(np.count_nonzero(fallbacks == Fallback.BRAKE)),
        "los_fallback_far_command": int(np.count_nonzero(fallbacks == Fallback.NOMINAL)),
        "los_fallback_best_effort": int(np.count_nonzero(fallbacks == Fallback.BEST_EFFORT)),
        "los_no_input_by_status": no_input_by_status(codes, fallbacks, regime[steps]),
        "los_regime_steps": {
            regime_kind.name.lower(): int(np.count_nonzero(regime[steps] == regime_kind))
            for regime_kind in Regime
        },
        "los_mpc_solve_ms_median": float(1e3 * np.median(out["los_mpc_solve_time_s"][steps])),
        "los_mpc_solve_ms_max": float(1e3 * np.max(out["los_mpc_solve_time_s"][steps])),
    }
    success = depth == 0.0 and held
    solver = _solver_text(summary)
    if success:
        text = (
            f"held at {config.hold_distance_m:g} m on the corridor axis from "
            f"{summary['los_hold_reached_s']:.0f} s, zero corridor violations (least margin "
            f"{min_distance:.2f} m); {solver}"
        )
    else:
        parts = []
        if depth > 0:
            parts.append(
                f"corridor violated {depth:.3f} m deep for {duration:.1f} s from {first:.1f} s"
            )
        if not held:
            parts.append(f"not holding at the end ({hold_distance:.1f} m from the hold point)")
        text = "NOT a success: " + "; ".join(parts) + f"; {solver}"
    return out, summary, MissionOutcome(success, text)
