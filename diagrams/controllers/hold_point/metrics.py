"""The hold-point controller's results: the hold errors, when the hold was reached, the mission.

Owns: `hold_errors` (position and speed error to the logged hold point at every sample), the
tolerances of the mission and `hold_results` (summary.json's entries and the outcome).
Does not own: the law (rpod.systems.hold_point_controller) or the run-level metrics
(rpod.diagrams.metrics).

Mission: the chaser holds the point `hold_distance_m` beyond the docking port, synchronised
with the tumble, to HOLD_POSITION_TOLERANCE_M and HOLD_SPEED_TOLERANCE_M_S at the end of the
run. `hold_reached_time_s` is the first log sample from which both hold at every later sample.
"""

import numpy as np

from rpod.diagrams.controller_seam import MissionOutcome
from rpod.models.frames import rotations_from_wxyz

HOLD_POSITION_TOLERANCE_M = 0.5  # "reached its hold point": within this of H ...
HOLD_SPEED_TOLERANCE_M_S = 0.02  # ... and moving with it to within this.


def hold_errors(log: dict) -> tuple[np.ndarray, np.ndarray]:
    """(position error [m], speed error [m/s]) to the logged hold point H at every sample.

    The speed error is against H's own velocity in L, w_LT x p_LH (H is fixed in T).
    """
    p_H = log["hold_point_L"]
    R_IL = rotations_from_wxyz(log["q_IL"])
    R_IT = rotations_from_wxyz(log["q_IT"])
    R_LT = np.transpose(R_IL, (0, 2, 1)) @ R_IT
    w_LT_L = np.einsum("nij,nj->ni", R_LT, log["w_IT_T"]) - log["w_IL_L"]
    position = np.linalg.norm(log["p_LC_L"] - p_H, axis=1)
    speed = np.linalg.norm(log["v_LC_L"] - np.cross(w_LT_L, p_H), axis=1)
    return position, speed


def hold_results(log: dict) -> tuple[dict, MissionOutcome]:
    """(summary.json's entries, the mission outcome) of a finished run (module docstring)."""
    position, speed = hold_errors(log)
    within = (position < HOLD_POSITION_TOLERANCE_M) & (speed < HOLD_SPEED_TOLERANCE_M_S)
    reached = bool(within[-1])
    # The first sample of the final run of samples inside the tolerances.
    outside = np.flatnonzero(~within)
    first = 0 if not len(outside) else int(outside[-1]) + 1
    reached_at = float(log["t"][first]) if reached else float("nan")
    summary = {
        "final_hold_error_m": float(position[-1]),
        "final_hold_speed_error_m_s": float(speed[-1]),
        "hold_reached": reached,
        "hold_reached_time_s": reached_at if reached else None,
    }
    if reached:
        text = (
            f"hold point reached at {reached_at:.1f} s, held to {position[-1]:.3f} m and "
            f"{speed[-1]:.4f} m/s"
        )
    else:
        text = (
            f"hold point NOT reached: at the end {position[-1]:.3f} m (tolerance "
            f"{HOLD_POSITION_TOLERANCE_M} m) and {speed[-1]:.4f} m/s (tolerance "
            f"{HOLD_SPEED_TOLERANCE_M_S} m/s) from it"
        )
    return summary, MissionOutcome(reached, text)
