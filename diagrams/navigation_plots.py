"""The figure a navigation engineer looks at first: each estimation error inside its +-3 sigma,
and the NEES against its chi-square bounds.

Owns: `NAVIGATION_FIGURES` (the figures of a run on `navigation: !Ekf`, in the form
`write_plots` takes from a controller plug-in: `log_shapes` and `run_figures()`).
Does not own: the errors and NEES (rpod.diagrams.navigation_results), the plotting kit
(rpod.diagrams.plots).
"""

from __future__ import annotations

import typing

import numpy as np
from matplotlib.figure import Figure

from rpod.diagrams.navigation_results import (
    CONVERGED_AFTER_S,
    KINEMATIC_DOF,
    kinematic_nees,
    nees_bounds,
)
from rpod.diagrams.plots import COMPONENT_COLOURS, LEGEND_OUTSIDE, RunLog, stacked_time_figure
from rpod.models import relative_navigation as rn
from rpod.models.frames import attitude_error

_PANELS = (  # (error group, label, scale to the unit shown)
    ("position", "position error [m]", 1.0),
    ("velocity", "velocity error [m/s]", 1.0),
    ("attitude", "target attitude error [deg]", np.degrees(1.0)),
    ("rate", "target rate error [deg/s]", np.degrees(1.0)),
)
_AXES = ("x", "y", "z")


def _errors(log: RunLog) -> np.ndarray | None:
    keys = ("p_LC_L", "nav_p_LC_L", "v_LC_L", "nav_v_LC_L", "q_IT", "nav_q_IT")
    keys += ("w_IT_T", "nav_w_IT_T")
    if any(log.get(key) is None for key in keys):
        return None
    attitude = np.array(
        [attitude_error(a, b) for a, b in zip(log.get("nav_q_IT"), log.get("q_IT"))]
    )
    return np.column_stack(
        [
            log.get("p_LC_L") - log.get("nav_p_LC_L"),
            log.get("v_LC_L") - log.get("nav_v_LC_L"),
            attitude,
            log.get("w_IT_T") - log.get("nav_w_IT_T"),
        ]
    )


def figure_navigation(log: RunLog, title: str) -> Figure | None:
    """navigation.png: per state group, the error's three components (truth minus estimate, in
    L for position and velocity, in T for attitude and rate) inside their +-3 sigma; then the
    NEES of the 12 kinematic states with its two-sided 95 % bounds."""
    errors = _errors(log)
    covariance = log.get("nav_covariance")
    if errors is None or covariance is None:
        return None
    sigma = np.sqrt(np.maximum(np.diagonal(covariance.reshape(-1, 14, 14), axis1=1, axis2=2), 0))
    nees = kinematic_nees(errors, covariance)
    low, high = nees_bounds()
    t = log.t

    def draw(kind, ax, edges):
        if kind == "nees":
            ax.semilogy(t, nees, color="k", lw=0.9, label=f"NEES ({KINEMATIC_DOF} states)")
            ax.axhline(KINEMATIC_DOF, color="tab:green", lw=0.9, ls="--", label="its mean")
            ax.axhspan(low, high, color="tab:green", alpha=0.12, label="95 % bounds")
            ax.axvline(CONVERGED_AFTER_S, color="0.5", lw=0.8, ls=":", label="judged from here")
            ax.set_ylabel("NEES [-]")
            ax.legend(**LEGEND_OUTSIDE)
            return
        group, label, scale = next(panel for panel in _PANELS if panel[0] == kind)
        columns = range(rn.GROUPS[group].start, rn.GROUPS[group].stop)
        for axis, column, colour in zip(_AXES, columns, COMPONENT_COLOURS):
            ax.plot(t, scale * errors[:, column], color=colour, lw=0.9, label=f"error {axis}")
            bound = 3.0 * scale * sigma[:, column]
            ax.fill_between(t, -bound, bound, color=colour, alpha=0.08, lw=0)
            ax.plot(t, bound, color=colour, lw=0.6, ls="--", label=f"+-3 sigma {axis}")
            ax.plot(t, -bound, color=colour, lw=0.6, ls="--")
        shown = scale * errors[:, list(columns)]
        limit = np.nanpercentile(np.abs(shown), 99.5) if np.isfinite(shown).any() else 1.0
        bound_limit = np.nanpercentile(3.0 * scale * sigma[:, list(columns)], 90)
        ax.set_ylim(-1.3 * max(limit, bound_limit), 1.3 * max(limit, bound_limit))
        ax.set_ylabel(label)
        ax.legend(**LEGEND_OUTSIDE)

    panels = [(group, 1.0) for group, _, _ in _PANELS] + [("nees", 1.0)]
    return stacked_time_figure(
        log, title, "Navigation: estimation error and +-3 sigma, NEES", panels, draw
    )


class _NavigationFigures:
    """The navigation's figures, handed to write_plots beside a controller plug-in's."""

    log_shapes: typing.ClassVar[dict] = {
        "nav_p_LC_L": 3,
        "nav_v_LC_L": 3,
        "nav_q_IT": 4,
        "nav_w_IT_T": 3,
        "nav_covariance": rn.ERROR_SIZE * rn.ERROR_SIZE,
    }

    def run_figures(self) -> dict:
        return {"navigation.png": figure_navigation}


NAVIGATION_FIGURES = _NavigationFigures()
