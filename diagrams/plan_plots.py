"""PNG plots of a soft-capture plan, after paper 000's Figs. 5-7 and 9.

Owns: `write_plan_plots` (the `plots/*.png` of `rpod plan`). Does not own: planning, the plan
file (rpod.scenarios.plan), or the plots of a simulated run (rpod.diagrams.plots).

Figures, one file each (`PLAN_FIGURE_NAMES`):
  trajectory.png  Fig. 5: the planned path in L (target hull at the final knot's pose, chaser
                  hull at a few knots, docking cone) and the same path in the target body
                  frame T, where the target stands still and the docking cone is fixed.
  thrust.png      Fig. 6: the planned force u_k in L (components and norm) with U_max.
  alpha.png       Figs. 7 and 9: the collision metric alpha_k with the hard limit 1 and the
                  soft margin alpha_min.
  state.png       Range |r_k| and speed |v_k| with their bounds, and the line-of-sight step
                  angle(r_k, r_k+1) against omega_max dt (the field of view, eq. 12).

Decisions: matplotlib through `matplotlib.figure.Figure` (no pyplot), written atomically (a
temporary file renamed over the final name, `rpod.diagrams.plots.save_figure`); a plan with
fewer than two knots draws nothing (and removes stale files of these names).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d import Axes3D  # noqa: F401  (registers the "3d" projection)
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from scipy.spatial import ConvexHull

from rpod.diagrams.plots import _equal_aspect_3d, save_figure
from rpod.models.frames import rotations_from_wxyz

_logger = logging.getLogger(__name__)

PLAN_FIGURE_NAMES = ("trajectory.png", "thrust.png", "alpha.png", "state.png")
_TARGET_COLOUR = (0.85, 0.65, 0.20)
_CHASER_COLOUR = (0.20, 0.45, 0.85)
_COMPONENT_COLOURS = ("tab:red", "tab:green", "tab:blue")


def _hull_faces(vertices: np.ndarray) -> list[np.ndarray]:
    """Triangles (3, 3) of the convex hull of vertices (V, 3)."""
    hull = ConvexHull(vertices)
    return [vertices[s] for s in hull.simplices]


def _draw_hull(ax, vertices_body, R, p, colour, alpha) -> None:
    posed = vertices_body @ R.T + p
    ax.add_collection3d(
        Poly3DCollection(
            _hull_faces(posed), facecolor=(*colour, alpha), edgecolor=(*colour, 0.6), linewidth=0.3
        )
    )


def _cone_lines(ax, R, apex_T, axis_T, half_angle, length, colour) -> None:
    """Eight generators and the rim of the docking cone (11), posed by R (T -> frame drawn)."""
    axis = axis_T / np.linalg.norm(axis_T)
    e1 = np.cross(axis, np.eye(3)[np.argmin(np.abs(axis))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    angles = np.linspace(0.0, 2.0 * np.pi, 33)
    radius = length * np.tan(half_angle)
    rim = (
        apex_T
        + length * axis
        + radius * (np.outer(np.cos(angles), e1) + np.outer(np.sin(angles), e2))
    )
    rim = rim @ R.T
    apex = R @ apex_T
    ax.plot(*rim.T, color=colour, lw=0.8)
    for point in rim[:-1:4]:
        ax.plot(*np.stack([apex, point]).T, color=colour, lw=0.8)


def _figure_trajectory(plan: Mapping, title: str) -> Figure:
    x = np.asarray(plan["x"], float)
    r = x[:, :3]
    R_LT = rotations_from_wxyz(plan["q_LT"])
    R_LC = rotations_from_wxyz(plan["q_LC"])
    V_t = np.asarray(plan["V_target"], float)
    V_c = np.asarray(plan["V_chaser"], float)
    D_t = np.asarray(plan["D_t"], float)
    theta = float(plan["theta_dock"])
    N = len(r)
    fig = Figure(figsize=(13.0, 6.0))
    fig.suptitle(
        f"{title} — planned trajectory (paper 000 Fig. 5)"
        if title
        else "Planned trajectory (paper 000 Fig. 5)"
    )
    chaser_knots = np.unique(np.r_[np.linspace(0, N - 1, 5).round().astype(int), N - 1])

    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax.set_title("in LVLH L (target at the final knot)")
    _draw_hull(ax, V_t, R_LT[-1], np.zeros(3), _TARGET_COLOUR, 0.35)
    for k in chaser_knots:
        _draw_hull(ax, V_c, R_LC[k], r[k], _CHASER_COLOUR, 0.12 if k < N - 1 else 0.35)
    _cone_lines(ax, R_LT[-1], D_t, D_t, theta, 4.0, "tab:green")
    ax.plot(*r.T, "-", color="tab:purple", lw=1.5, label="planned r_k")
    ax.plot(*r[:1].T, "o", color="tab:green", label="start")
    ax.plot(*r[-1:].T, "s", color="tab:red", label="final knot")
    ax.set_xlabel("x (radial) [m]")
    ax.set_ylabel("y (along-track) [m]")
    ax.set_zlabel("z (normal) [m]")
    ax.legend(loc="upper left", fontsize=8)
    _equal_aspect_3d(ax, np.vstack([r, V_t @ R_LT[-1].T]))

    ax = fig.add_subplot(1, 2, 2, projection="3d")
    ax.set_title("in the target body frame T")
    r_T = np.einsum("kji,kj->ki", R_LT, r)  # R_LT^T r_k
    R_TC = np.einsum("kji,kjl->kil", R_LT, R_LC)
    _draw_hull(ax, V_t, np.eye(3), np.zeros(3), _TARGET_COLOUR, 0.35)
    for k in chaser_knots:
        _draw_hull(ax, V_c, R_TC[k], r_T[k], _CHASER_COLOUR, 0.12 if k < N - 1 else 0.35)
    _cone_lines(ax, np.eye(3), D_t, D_t, theta, 4.0, "tab:green")
    ax.plot(*r_T.T, "-", color="tab:purple", lw=1.5)
    ax.plot(*r_T[:1].T, "o", color="tab:green")
    ax.plot(*r_T[-1:].T, "s", color="tab:red")
    ax.set_xlabel("x_T [m]")
    ax.set_ylabel("y_T [m]")
    ax.set_zlabel("z_T [m]")
    _equal_aspect_3d(ax, np.vstack([r_T, V_t]))
    return fig


def _figure_thrust(plan: Mapping, title: str) -> Figure:
    t = np.asarray(plan["t"], float)
    u = np.asarray(plan["u"], float)
    fig = Figure(figsize=(10.0, 6.0))
    axes = fig.subplots(2, 1, sharex=True)
    fig.suptitle(
        f"{title} — thrust profile (paper 000 Fig. 6)"
        if title
        else "Thrust profile (paper 000 Fig. 6)"
    )
    edges = t  # u_k is held over [t_k, t_k+1)
    for i, name in enumerate("xyz"):
        axes[0].stairs(u[:, i], edges, color=_COMPONENT_COLOURS[i], label=f"u_{name} (L)")
    axes[0].set_ylabel("force [N]")
    axes[0].legend(fontsize=8, ncol=3)
    axes[0].grid(alpha=0.3)
    axes[1].stairs(np.linalg.norm(u, axis=1), edges, color="k", label="|u_k|")
    axes[1].axhline(float(plan["U_max"]), color="tab:red", ls="--", label="U_max (9)")
    axes[1].set_ylabel("|u| [N]")
    axes[1].set_xlabel("t [s]")
    axes[1].legend(fontsize=8)
    axes[1].grid(alpha=0.3)
    return fig


def _figure_alpha(plan: Mapping, title: str) -> Figure:
    t = np.asarray(plan["t"], float)
    alpha = np.asarray(plan["alpha"], float)
    fig = Figure(figsize=(10.0, 4.5))
    ax = fig.subplots()
    fig.suptitle(
        f"{title} — collision metric (paper 000 Figs. 7, 9)"
        if title
        else "Collision metric (paper 000 Figs. 7, 9)"
    )
    ax.plot(t, alpha, "o-", ms=3, color="tab:purple", label="alpha_k (planned)")
    if "alpha_check" in plan:
        ax.plot(
            t,
            np.asarray(plan["alpha_check"], float),
            "x",
            ms=4,
            color="k",
            label="alpha_k (independent LP)",
        )
    ax.axhline(1.0, color="tab:red", ls="-", label="alpha = 1 (contact)")
    ax.axhline(float(plan["alpha_min"]), color="tab:orange", ls="--", label="alpha_min (soft)")
    if np.all(alpha > 0) and alpha.max() / max(alpha.min(), 1e-12) > 20:
        ax.set_yscale("log")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("alpha")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return fig


def _figure_state(plan: Mapping, title: str) -> Figure:
    t = np.asarray(plan["t"], float)
    x = np.asarray(plan["x"], float)
    r, v = x[:, :3], x[:, 3:]
    fig = Figure(figsize=(10.0, 7.5))
    axes = fig.subplots(3, 1, sharex=True)
    fig.suptitle(
        f"{title} — range, speed, line of sight" if title else "Range, speed, line of sight"
    )
    axes[0].plot(t, np.linalg.norm(r, axis=1), color="k", label="|r_k|")
    axes[0].set_ylabel("range [m]")
    axes[1].plot(t, np.linalg.norm(v, axis=1), color="k", label="|v_k|")
    axes[1].axhline(float(plan["v_max"]), color="tab:red", ls="--", label="v_max (10)")
    axes[1].set_ylabel("speed [m/s]")
    angles = np.arctan2(
        np.linalg.norm(np.cross(r[:-1], r[1:]), axis=1), np.sum(r[:-1] * r[1:], axis=1)
    )
    axes[2].stairs(np.degrees(angles), t, color="k", label="angle(r_k, r_k+1)")
    limit = np.degrees(float(plan["omega_max"]) * float(plan["dt"]))
    axes[2].axhline(limit, color="tab:red", ls="--", label="omega_max dt (12)")
    axes[2].set_ylabel("LOS step [deg]")
    axes[2].set_xlabel("t [s]")
    for ax in axes:
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    return fig


_FIGURES = {
    "trajectory.png": _figure_trajectory,
    "thrust.png": _figure_thrust,
    "alpha.png": _figure_alpha,
    "state.png": _figure_state,
}
assert tuple(_FIGURES) == PLAN_FIGURE_NAMES


def write_plan_plots(plan: Mapping, out_dir: Path, title: str = "") -> list[Path]:
    """Writes the plan's PNG figures into out_dir (created if needed).

    Args:
        plan: The arrays of plan.npz (a dict or an `np.load`ed npz): t (N), x (N, 6), u (N-1, 3),
            q_LT and q_LC (N, 4), alpha (N), optional alpha_check (N), V_target and V_chaser
            (polytope vertices in T and C), D_t (3), and the scalars theta_dock, U_max, v_max,
            omega_max, dt, alpha_min.
        out_dir: Output folder, e.g. runs/<scenario>-plan/plots.
        title: Prefix of every figure's title.

    Returns:
        The paths written, in `PLAN_FIGURE_NAMES` order. A figure that fails to draw is logged
        as a warning and skipped (plots are a side output).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    drawable = len(np.asarray(plan["t"])) >= 2
    written = []
    for name, make in _FIGURES.items():
        path = out_dir / name
        if not drawable:
            path.unlink(missing_ok=True)
            continue
        try:
            save_figure(make(plan, title), path)
            written.append(path)
        except Exception:  # a side output: never lose the others
            _logger.warning("plan plots: could not draw %s", name, exc_info=True)
            path.unlink(missing_ok=True)
    return written
