"""Paper 001's coupled NMPC: the mission's verdict and its one line.

Owns: `coupled_outcome`. Does not own: the measures and thresholds it reads (metrics.py).

Mission: success = converged at the end (and so from coupled_converged_at_s on) AND no
constraint excess (metrics.py's thresholds). Every step whose solve was not usable is counted
and named in the line (status and fallback); it fails the mission only through what it leads
to. The LOS pyramid is reported, not judged.
"""

from rpod.diagrams.controller_seam import MissionOutcome
from rpod.diagrams.controllers.coupled_nmpc.metrics import (
    ATTITUDE_TOLERANCE_DEG,
    DISTANCE_TOLERANCE_M,
)


def coupled_outcome(summary: dict) -> MissionOutcome:
    """The verdict of a run from its summary.json entries (module docstring)."""
    converged = summary["coupled_converged"]
    excess = summary["coupled_constraint_excess"]
    failed = summary["nmpc_not_usable"]
    solver = f"{summary['nmpc_solves']} solves, {failed} not usable"
    if failed:
        kinds = ", ".join(
            f"{status} {count}" for status, count in summary["nmpc_not_usable_by_status"].items()
        )
        solver += (
            f" ({kinds}; fallback: {summary['nmpc_fallback_previous_plan']} previous plan, "
            f"{summary['nmpc_fallback_zero_thrust']} zero thrust)"
        )
    los = summary["coupled_los_last_violation_s"]
    if los is None:
        los_text = "LOS never violated"
    elif summary["coupled_los_violated_at_end"]:
        los_text = "LOS violated at the end"
    else:
        los_text = f"LOS held after {los:.0f} s"
    final = (
        f"{summary['coupled_final_eigenaxis_error_deg']:.3g} deg, "
        f"{summary['coupled_final_distance_m']:.3g} m, "
        f"{summary['coupled_final_speed_m_s']:.3g} m/s at the end"
    )
    parts = []
    if converged:
        parts.append(f"grasp pose from {summary['coupled_converged_at_s']:.0f} s: {final}")
    else:
        parts.append(
            f"grasp pose NOT held at the end ({final}; tolerance {ATTITUDE_TOLERANCE_DEG:g} "
            f"deg, {DISTANCE_TOLERANCE_M:g} m)"
        )
    if excess:
        parts.append(
            f"thruster limits exceeded (gimbal {summary['coupled_max_gimbal_excess_N']:.3g} N, "
            f"magnitude {summary['coupled_max_magnitude_excess_N']:.3g} N)"
        )
    parts += [los_text, solver]
    return MissionOutcome(bool(converged and not excess), "; ".join(parts))
