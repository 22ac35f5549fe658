"""What a run on `navigation: !Ekf` says about its estimate: log arrays and summary statistics.

Owns: `navigation_log` (the navigation's logged ports as named arrays of log.npz) and
`navigation_summary` (summary.json's `navigation` block: the error of each state group, RMS and
final, its NEES against the chi-square bounds, the fixes used, rejected and unseen).
Does not own: the filter (rpod.models.relative_navigation), its figures
(rpod.diagrams.navigation_plots).

The error is the estimate the controller read (the `sensed` output, carried to the sample's
instant) against the truth logged at the same instant; the covariance is the filter's at its
last tick before that (at most one update period older). NEES is taken over the 12 kinematic
error states [dp, dv, dtheta_T, dw_T]: the inertia parameters' truth is defined only when the
target's principal axes are T's (a diagonal inertia), so their error is reported apart.
"""

from __future__ import annotations

import numpy as np

from rpod.models import relative_navigation as rn
from rpod.systems.navigation import STATUS_FIELDS

KINEMATIC = slice(0, 12)
KINEMATIC_DOF = 12
GROUP_UNITS = {"position": "m", "velocity": "m/s", "attitude": "deg", "rate": "deg/s"}
CONVERGED_AFTER_S = 30.0
"""NEES is judged from this long after the start (the lead-in's filter is still settling)."""


def navigation_log(data: dict, count: int) -> dict:
    """The named arrays of the navigation's logged ports (`data`: logger key -> samples)."""
    sensed = data["navigation_sensed"][:count]
    estimate = data["navigation_estimate"][:count]
    return {
        "nav_p_LC_L": sensed[:, 0:3],
        "nav_v_LC_L": sensed[:, 3:6],
        "nav_q_IT": sensed[:, 13:17],
        "nav_w_IT_T": sensed[:, 17:20],
        "nav_q_IC": sensed[:, 20:24],
        "nav_p_IT_I": sensed[:, 27:30],
        "nav_inertia_parameters": estimate[:, 13:15],
        "nav_covariance": data["navigation_covariance"][:count],
        "nav_status": data["navigation_status"][:count],
    }


def _attitude_errors(q_ref: np.ndarray, q: np.ndarray) -> np.ndarray:
    return np.array([rn.attitude_error(a, b) for a, b in zip(q_ref, q)])


def estimation_errors(log: dict) -> np.ndarray:
    """The error (N, 12) [dp, dv, dtheta_T, dw_T] of the estimate, truth minus estimate, in the
    filter's error-state convention (dtheta_T: the true attitude about the estimate, in T)."""
    return np.column_stack(
        [
            log["p_LC_L"] - log["nav_p_LC_L"],
            log["v_LC_L"] - log["nav_v_LC_L"],
            _attitude_errors(log["nav_q_IT"], log["q_IT"]),
            log["w_IT_T"] - log["nav_w_IT_T"],
        ]
    )


def kinematic_nees(errors: np.ndarray, covariance: np.ndarray) -> np.ndarray:
    """NEES (N,) of the 12 kinematic errors with the logged covariances (N, 196)."""
    nees = np.full(len(errors), np.nan)
    for i, (e, flat) in enumerate(zip(errors, covariance)):
        P = flat.reshape(rn.ERROR_SIZE, rn.ERROR_SIZE)[KINEMATIC, KINEMATIC]
        if np.all(np.isfinite(P)) and np.all(np.isfinite(e)):
            nees[i] = float(e @ np.linalg.solve(P, e))
    return nees


def nees_bounds(probability: float = 0.95, dof: int = KINEMATIC_DOF) -> tuple[float, float]:
    """The two-sided chi-square bounds of one NEES sample."""
    tail = 0.5 * (1.0 - probability)
    return rn.chi_square_quantile(tail, dof), rn.chi_square_quantile(1.0 - tail, dof)


def navigation_summary(log: dict, true_inertia_kg_m2) -> dict:
    """summary.json's `navigation` block (module docstring)."""
    errors = estimation_errors(log)
    scale = np.ones(12)
    scale[6:12] = np.degrees(1.0)
    shown = errors * scale
    groups = {}
    for name, unit in GROUP_UNITS.items():
        part = shown[:, rn.GROUPS[name]]
        norm = np.linalg.norm(part, axis=1)
        groups[name] = {
            "unit": unit,
            "rms": float(np.sqrt(np.nanmean(norm**2))),
            "max": float(np.nanmax(norm)),
            "final": float(norm[-1]),
        }
    nees = kinematic_nees(errors, log["nav_covariance"])
    settled = log["t"] >= CONVERGED_AFTER_S
    low, high = nees_bounds()
    judged = nees[settled & np.isfinite(nees)]
    status = log["nav_status"][-1]
    summary = {
        "estimator": "ekf",
        "errors": groups,
        "nees_mean": float(np.mean(judged)) if judged.size else None,
        "nees_dof": KINEMATIC_DOF,
        "nees_inside_95_share": (
            float(np.mean((judged >= low) & (judged <= high))) if judged.size else None
        ),
        "nees_judged_after_s": CONVERGED_AFTER_S,
        **{name: int(value) for name, value in zip(STATUS_FIELDS[:4], status[:4])},
    }
    J = np.asarray(true_inertia_kg_m2, dtype=float)
    estimate = log["nav_inertia_parameters"][-1]
    ratios = rn.ratios_from_parameters(estimate)
    summary["inertia_ratios"] = {
        "estimate": [float(r) for r in ratios],
        "truth": (
            [float(J[1, 1] / J[0, 0]), float(J[2, 2] / J[0, 0])]
            if np.allclose(J, np.diag(np.diag(J)))
            else None  # principal axes not T's: the filter's model does not hold exactly
        ),
        "sigma_parameters": [
            float(np.sqrt(log["nav_covariance"][-1].reshape(14, 14)[i, i])) for i in (12, 13)
        ],
    }
    return summary
