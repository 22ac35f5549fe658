"""The run-level metrics of summary.json, read from a finished run's log.

Owns: `run_summary` (time, delta-v and propellant, separation, the corridor violation inside
the corridor's extent, the final state) for every run, whatever its controller.
Does not own: a controller's own metrics and mission outcome (its plug-in's `results`).
"""

import math

import numpy as np

from rpod.diagrams.scenario import Scenario
from rpod.models.thrusters import STANDARD_GRAVITY_M_S2


def _max_in_corridor(log: dict, corridor_length_m: float) -> float | None:
    """The largest corridor violation [deg] at the samples within the corridor's extent
    (port_distance_m <= corridor_length_m): negative when always inside the cone (the least
    margin), None when the chaser never came within the extent."""
    inside = log["port_distance_m"] <= corridor_length_m
    if not np.any(inside):
        return None
    return float(np.degrees(np.max(log["corridor_violation_rad"][inside])))


def run_summary(log: dict, scenario: Scenario) -> dict:
    """Metrics of a finished run (see README, 'Outputs')."""
    mass0, mass = scenario.chaser.mass_kg, log["chaser_mass_kg"][-1]
    isp = scenario.thrusters.isp_s
    summary = {
        "sim_time_s": float(log["t"][-1]),
        # Sum over thrusters of impulse / mass: with one Isp, exactly g0 Isp ln(m0 / m).
        "delta_v_m_s": float(STANDARD_GRAVITY_M_S2 * isp * math.log(mass0 / mass)),
        "propellant_kg": float(mass0 - mass),
        "min_separation_m": float(np.min(log["separation_m"])),
        # Only where the capture point is within the corridor's extent (TargetConfig).
        "max_corridor_violation_deg": _max_in_corridor(log, scenario.target.corridor_length_m),
        "final_p_LC_L": log["p_LC_L"][-1].tolist(),
        "final_range_m": float(np.linalg.norm(log["p_LC_L"][-1])),
        "final_speed_m_s": float(np.linalg.norm(log["v_LC_L"][-1])),
        "final_capture_speed_m_s": float(log["capture_speed_m_s"][-1]),
        "clipped_command_samples": int(np.count_nonzero(log["command_clipped"])),
    }
    return summary
