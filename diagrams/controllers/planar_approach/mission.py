"""Paper 003's planar approach: the mission's verdict and its one line.

Owns: `outcome`. Does not own: the summary entries it reads (metrics.py).

Mission (chosen here; the paper states no tolerance): success = the plan is a success (its own
end point within `goal_position_tolerance_m` of the goal: a plan that misses is GOAL_MISSED,
flown for its figures and never a success) AND the true shapes never touch over the whole run
(`separation_m` > 0 at every log sample, and the core's ContactWatch, summary["contact"], at
every integrator step; a contact in the hold after the arrival fails the mission too,
`planar_contact_after_arrival_s` says when it began: the hold needs m omega^2 r of centripetal
force, `planar_hold_force_ratio` times what the thrusters give along an axis) AND at the
planned arrival T (the first log sample at or after it) the chaser is
within `goal_position_tolerance_m` (5 cm) of the goal x_goal of eq. 5, within
`goal_attitude_tolerance_deg` (5 deg) of theta_finish (eq. 6) and moves relative to the
target's docking face (in the target frame, Fig. 7) at most `goal_speed_tolerance_m_s` (0.03
m/s: the allowable contact velocity the paper cites, Sasaki et al.). A campaign's table
(`rpod report`) leads with the mission success share (Wilson 95 %), then the safety figures:
`planar_safe` = the plan reached its goal and the true shapes never touched in the whole run.
"""

from rpod.diagrams.controller_seam import MissionOutcome
from rpod.diagrams.controllers.planar_approach.config import PlanarApproach


def outcome(summary: dict, block: PlanarApproach) -> MissionOutcome:
    """The mission verdict and its one line (module docstring)."""
    if not summary.get("planar_plan_flown", summary["planar_plan_success"]):
        return MissionOutcome(
            False,
            f"NOT a success, NOT flown: plan {summary['planar_plan_status']}: "
            f"{summary['planar_plan_message']}; held the start pose",
        )
    rms = summary["planar_rms_tracking_error_m"]
    terminal = (
        f"at arrival {summary['planar_terminal_time_s']:.1f} s: "
        f"{summary['planar_terminal_position_error_m']:.3f} m from the goal, "
        f"{summary['planar_terminal_relative_speed_m_s']:.3f} m/s relative, "
        f"{summary['planar_terminal_attitude_error_deg']:.1f} deg"
    )
    switches = summary["planar_switches"]
    tail = (
        f"RMS tracking error {100.0 * rms:.2f} cm; final relative speed "
        f"{summary['planar_final_relative_speed_m_s']:.4f} m/s; delta-v to arrival "
        f"{summary['planar_delta_v_m_s']:.4f} m/s"
        + (f"; {switches} thruster switches" if switches is not None else "")
    )
    later = summary["planar_contact_after_arrival_s"]
    if later is not None:
        why = (
            "released at the arrival"
            if summary["planar_after_plan"] == "release"
            else f"the co-rotating hold needs {summary['planar_hold_force_ratio']:.2g}x the "
            "thrusters' force"
        )
        tail += f"; contact after the arrival at {later:.2f} s ({why})"
    missed = ""
    if not summary["planar_plan_success"]:  # flown, but the plan itself misses its goal
        missed = f"the plan missed its goal ({summary['planar_plan_message']}); "
    if summary["planar_contact"]:
        planned = summary["planar_plan_contact_s"]
        where = (
            f"; the plan itself touches from {planned:.1f} s"
            if planned is not None
            else "; the plan does not touch"
        )
        return MissionOutcome(
            False,
            f"NOT a success: contact at {summary['planar_first_contact_s']:.2f} s (true shapes "
            f"touched{where}); {missed}{terminal}; {tail}",
        )
    if missed or not summary["planar_goal_reached"]:
        reached = "reached" if summary["planar_goal_reached"] else "NOT reached"
        return MissionOutcome(
            False,
            f"NOT a success: {missed}goal {reached} {terminal} (tolerances "
            f"{block.goal_position_tolerance_m:g} m, {block.goal_speed_tolerance_m_s:g} m/s, "
            f"{block.goal_attitude_tolerance_deg:g} deg); no contact in the run; {tail}",
        )
    return MissionOutcome(True, f"approached, no contact in the run, {terminal}; {tail}")
