"""Paper 000's soft capture: a run's results, from its log and its planner records.

Owns: `capture_outcome` (the capture criterion on a log), `plan_knots` (the accepted plans'
knots for log.npz) and `soft_capture_results` (the log additions, summary.json's entries:
capture, every planner call, the docking cone's violation up to the capture; and the mission
outcome).
Does not own: the planner records themselves (rpod.systems.soft_capture_controller), the
run-level metrics (rpod.diagrams.metrics) or the campaign table (tables.py).

Mission: capture (paper 000's eps_p, eps_v on the capture points, no contact before).
"""

import math

import numpy as np

from rpod.diagrams.controller_seam import MissionOutcome
from rpod.diagrams.mission import judge_capture
from rpod.models.frames import rotation_from_wxyz
from rpod.systems.soft_capture_controller import MODE_FALLBACK, PLANNER_STATUSES
from rpod.systems.soft_capture_controller import MODES as CONTROLLER_MODES


def capture_outcome(log: dict, scenario) -> dict:
    """The soft-capture criterion on a run's log (paper 000's eps_p, eps_v; Table I).

    Capture succeeds at the first log sample where the capture points -- the chaser's D_c
    (`chaser.capture_point_C`, in C) and the target's D_t (`target.docking_port_T`, in T) --
    are within eps_p of each other and their relative (inertial) speed is within eps_v
    (`capture_speed_m_s` of the SafetyMonitor), provided the true polytopes never touched
    before (`separation_m` > 0 at every sample up to and including that one). Contact is
    checked at the log samples: log at the control period for a run whose verdict matters.
    The criterion is `mission: !Capture`'s (rpod.diagrams.mission.judge_capture), on the
    capture points' distance computed here from the logged poses, with the planner's
    tolerances.

    Returns:
        {success, reason, time_s, position_error_m, speed_error_m_s, contact_after_s}: the
        errors at the capture sample, or at the sample closest to meeting both tolerances
        (least max(position / eps_p, speed / eps_v)) when it failed; `contact_after_s` is the
        first contact after a successful capture (NaN if none: contact after capture does not
        undo it, but a hold the thrusters cannot sustain -- a fast tumble needs more
        centripetal force than they have -- ends in one, and a user should see it).
    """
    settings = scenario.controller.planner
    D_c = np.asarray(scenario.chaser.capture_point_C, float)
    D_t = np.asarray(scenario.target.docking_port_T, float)
    position_error = np.empty(len(log["t"]))
    for i, (p_LC_L, q_IL, q_IT, q_IC) in enumerate(
        zip(log["p_LC_L"], log["q_IL"], log["q_IT"], log["q_IC"])
    ):
        R_LI = rotation_from_wxyz(q_IL).T
        p_E_L = p_LC_L + R_LI @ rotation_from_wxyz(q_IC) @ D_c  # chaser capture point
        p_D_L = R_LI @ rotation_from_wxyz(q_IT) @ D_t  # target capture point
        position_error[i] = np.linalg.norm(p_E_L - p_D_L)
    outcome = judge_capture(
        log["t"],
        position_error,
        log["capture_speed_m_s"],
        log["separation_m"],
        settings.capture_position_tol_m,
        settings.capture_speed_tol_m_s,
    )
    first_contact = outcome.pop("first_contact_s")
    outcome["contact_after_s"] = first_contact if outcome["success"] else float("nan")
    return outcome


def _json_safe(record: dict) -> dict:
    """The record with non-finite floats as None (strict JSON has no NaN)."""
    return {
        key: None if isinstance(value, float) and not math.isfinite(value) else value
        for key, value in record.items()
    }


def plan_knots(records: list[dict], dt: float) -> dict:
    """`plan_knots_t` (P, N_max), `plan_knots_p_LC_L`, `plan_knots_v_LC_L` (P, N_max, 3) and
    `plan_knots_u_L` (P, N_max - 1, 3) of the accepted plans, NaN-padded."""
    accepted = [r for r in records if r["accepted"]]
    width = max((len(r["x"]) for r in accepted), default=1)
    t = np.full((len(accepted), width), np.nan)
    x = np.full((len(accepted), width, 6), np.nan)
    u = np.full((len(accepted), width - 1, 3), np.nan)
    for i, record in enumerate(accepted):
        knots = np.asarray(record["x"], float)
        t[i, : len(knots)] = record["t_s"] + np.arange(len(knots)) * dt
        x[i, : len(knots)] = knots
        u[i, : len(knots) - 1] = np.asarray(record["u"], float)
    return {
        "plan_knots_t": t,
        "plan_knots_p_LC_L": x[..., :3],
        "plan_knots_v_LC_L": x[..., 3:],
        "plan_knots_u_L": u,
    }


def _outcome_text(capture: dict) -> str:
    if capture["success"]:
        text = (
            f"captured at {capture['time_s']:.1f} s to {capture['position_error_m']:.3f} m and "
            f"{capture['speed_error_m_s']:.3f} m/s"
        )
        if math.isfinite(capture["contact_after_s"]):
            text += f" (contact after capture at {capture['contact_after_s']:.1f} s)"
        return text
    return f"NOT captured: {capture['reason']}"


def soft_capture_results(scenario, records: list[dict], log: dict):
    """(log additions, summary.json's entries, mission outcome) of a finished run from its log
    and the controller's planner records; `log` is read, never changed."""
    dt = scenario.controller.planner.dt_s
    # The logged (N, 1) codes as int64 (N,), and the accepted plans' knots.
    extra_log = {
        key: log[key][:, 0].astype(np.int64) for key in ("controller_mode", "planner_status")
    }
    extra_log.update(plan_knots(records, dt))
    capture = capture_outcome(log, scenario)
    accepted = [r for r in records if r["accepted"]]
    capture["planned_time_s"] = (
        accepted[-1]["t_s"] + (accepted[-1]["N"] - 1) * dt if accepted else float("nan")
    )
    if not accepted and not capture["success"]:
        last = records[-1] if records else {"status": "none", "reason": "no planner call"}
        capture["reason"] = f"no plan: {last['status']}: {last['reason']}"
    first = records[0] if records else {}
    last_call = records[-1]["status"] if records else "none"
    summary = {
        "capture": _json_safe(capture),
        "plans": [
            _json_safe(
                {key: value for key, value in r.items() if key not in ("x", "u")}
                | {"check_violations": _json_safe(r.get("check_violations", {}))}
            )
            for r in records
        ],
        # What a user reads it for: the status of the plan being flown at the end (the
        # last accepted one); a late replan that fails keeps that plan flying.
        "planner_status": accepted[-1]["status"] if accepted else last_call,
        "last_planner_call_status": last_call,
    }
    summary.update(
        _json_safe(
            {
                "capture_success": bool(capture["success"]),
                "capture_time_s": capture["time_s"],
                "capture_position_error_m": capture["position_error_m"],
                "capture_speed_error_m_s": capture["speed_error_m_s"],
                "initial_plan_success": bool(first.get("accepted", False)),
                "initial_plan_N": int(first.get("N", 0)),
                "initial_plan_scp_iterations": int(first.get("scp_iterations", 0)),
                "initial_plan_solve_time_s": float(first.get("total_solve_time_s", 0.0)),
                "replans_accepted": sum(1 for r in records[1:] if r["accepted"]),
                "replans_failed": sum(1 for r in records[1:] if not r["accepted"]),
                # The independent plan check of every plan the planner called a success (None: the
                # initial call had no such plan).
                "plans_checked": sum(1 for r in records if r.get("check_passed") is not None),
                "plans_check_failed": sum(1 for r in records if r.get("check_passed") is False),
                "initial_plan_check_passed": first.get("check_passed"),
                "contact_after_capture": bool(capture["success"])
                and math.isfinite(capture["contact_after_s"]),
                # The seam's names for every method (rpod.diagrams.controller_seam.
                # ControllerResults): planner calls without an accepted plan, and the time
                # flown without a plan (zero wrench; to the log's period).
                "solver_failures": sum(1 for r in records if not r["accepted"]),
                "fallback_s": float(
                    np.count_nonzero(extra_log["controller_mode"] == MODE_FALLBACK)
                    * scenario.log_period_s
                ),
            }
        )
    )
    # The corridor a user reads this run for is paper 000's docking cone (eq. 11), which the
    # plan enforces over its last N_dock knots: the violation there, up to the capture.
    window = None
    if accepted:
        settings = scenario.controller.planner
        start = capture["planned_time_s"] - (settings.docking_knots - 1) * dt
        end = capture["time_s"] if capture["success"] else capture["planned_time_s"]
        inside = (log["t"] >= start - 1e-9) & (log["t"] <= end + 1e-9)
        if np.any(inside):
            window = [float(start), float(end)]
            summary["max_corridor_violation_deg"] = float(
                np.degrees(np.max(log["corridor_violation_rad"][inside]))
            )
    summary["corridor_window_s"] = window
    summary["planner_status_codes"] = list(PLANNER_STATUSES)
    summary["controller_mode_codes"] = list(CONTROLLER_MODES)
    outcome = MissionOutcome(bool(capture["success"]), _outcome_text(capture))
    return extra_log, summary, outcome
