"""PNG plots of soft-capture plans, after paper 000's Figs. 5-9.

Owns: `FIGURES`, the figures of one plan ({name: draw(arrays of plan.npz, title)}: the
`plots/*.png` of `rpod plan`, through plan_file.py), `write_scp_correction_plots` (Figs.
5-7: Problem 2's solution beside the SCP's corrected one), `write_start_outcomes_plot` (Fig. 8:
the outcome of each sampled start) and `write_alpha_overlay_plot` (Fig. 9: alpha_k of many
plans). Does not own: planning, the plan file (plan_file.py, rpod.scenarios.plan), the campaign that makes
the plans (benchmarks/soft_capture_figures.py), or the plots of a simulated run
(rpod.diagrams.plots).

Figures, one file each (`PLAN_FIGURE_NAMES`):
  trajectory.png  Fig. 5: the planned path in L (target hull at the final knot's pose, chaser
                  hull at a few knots, docking cone) and the same path in the target body
                  frame T, where the target stands still and the docking cone is fixed.
  thrust.png      Fig. 6: the planned force u_k in L (components and norm) with U_max.
  alpha.png       Figs. 7 and 9: the collision metric alpha_k with the hard limit 1 and the
                  soft margin alpha_min.
  state.png       Range |r_k| and speed |v_k| with their bounds, and the line-of-sight step
                  angle(r_k, r_k+1) against omega_max dt (the field of view, eq. 12).

Figures of several plans (`SCP_FIGURE_NAMES`, then one file each for Figs. 8 and 9):
  fig5_trajectory.png  Problem 2's path beside the SCP's, in T (where the target and the
                       docking cone stand still), knots with alpha_k <= 1 marked, the chaser
                       hull at Problem 2's worst knot.
  fig6_thrust.png      u_k of both (components, then norms with U_max).
  fig7_alpha.png       alpha_k of Problem 2 and of every SCP iterate: all knots (log scale)
                       and the final knots (linear).
  Fig. 8               tumble rate against start range, one marker per start, coloured by the
                       planner's status, with the count of each status in the legend.
  Fig. 9               alpha_k against t of every plan given, alpha = 1 and alpha_min, the least
                       alpha_k in the legend; optionally coloured by a value per plan.

Decisions: matplotlib through `matplotlib.figure.Figure` (no pyplot), written atomically (a
temporary file renamed over the final name, `rpod.diagrams.plots.save_figure`); a plan with
fewer than two knots draws nothing (and removes stale files of these names). The figures of
several plans are asked for by name, so they raise ValueError on empty or mismatched input
instead of writing an empty figure.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib
import matplotlib.cm
import matplotlib.colors
import matplotlib.ticker
import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d import Axes3D  # noqa: F401  (registers the "3d" projection)
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from scipy.spatial import ConvexHull

from rpod.diagrams.plots import equal_aspect_3d, save_figure
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
    equal_aspect_3d(ax, np.vstack([r, V_t @ R_LT[-1].T]))

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
    equal_aspect_3d(ax, np.vstack([r_T, V_t]))
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


FIGURES = {
    "trajectory.png": _figure_trajectory,
    "thrust.png": _figure_thrust,
    "alpha.png": _figure_alpha,
    "state.png": _figure_state,
}
assert tuple(FIGURES) == PLAN_FIGURE_NAMES


SCP_FIGURE_NAMES = ("fig5_trajectory.png", "fig6_thrust.png", "fig7_alpha.png")
_STATUS_STYLES = (  # (colour, filled marker) of the failure statuses, in order of first use
    ("tab:red", "X"),
    ("tab:orange", "^"),
    ("tab:purple", "s"),
    ("tab:brown", "D"),
    ("tab:pink", "v"),
    ("tab:gray", "P"),
    ("tab:olive", "*"),
    ("tab:cyan", "<"),
)


def _plain_log_y(ax) -> None:
    """A log y axis with ticks at 1, 2, 5 x 10^n written as plain numbers."""
    ax.set_yscale("log")
    ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())


def _iterate_label(i: int, last: int) -> str:
    if i == 0:
        return "Problem 2 (no collision rows)"
    return f"SCP iteration {i}" + (" (the plan)" if i == last else "")


def _iterate_colours(count: int) -> list:
    """Problem 2 grey, the SCP iterates along viridis, the last one purple."""
    colours = ["tab:gray"]
    if count > 2:
        colours += [matplotlib.colormaps["viridis"](v) for v in np.linspace(0.3, 0.8, count - 2)]
    if count > 1:
        colours.append("tab:purple")
    return colours


def _check_iterates(iterates: Sequence[Mapping]) -> None:
    if len(iterates) < 1:
        raise ValueError("no iterates to draw: give Problem 2's solution and the SCP's")
    for i, plan in enumerate(iterates):
        if len(np.asarray(plan["t"])) < 2:
            raise ValueError(f"iterate {i} has fewer than two knots")


def _tail_start(alpha: np.ndarray, alpha_min: float, knots: int = 15) -> int:
    """First knot of the zoomed views: 5 before the first alpha_k <= alpha_min, at most `knots`
    from the end."""
    N = len(alpha)
    low = np.flatnonzero(alpha <= alpha_min)
    return max(0, min(N - knots, (int(low[0]) if len(low) else N) - 5))


def _figure_scp_trajectory(iterates: Sequence[Mapping], title: str) -> Figure:
    first, last = iterates[0], iterates[-1]
    V_t = np.asarray(last["V_target"], float)
    V_c = np.asarray(last["V_chaser"], float)
    D_t = np.asarray(last["D_t"], float)
    theta = float(last["theta_dock"])
    first_alpha = np.asarray(first["alpha"], float)
    worst = int(np.argmin(first_alpha))  # Problem 2's worst knot
    tail = _tail_start(first_alpha, float(last["alpha_min"]))
    shown = [(0, first)] + ([(len(iterates) - 1, last)] if len(iterates) > 1 else [])
    fig = Figure(figsize=(6.0 * len(shown), 11.0))
    fig.subplots_adjust(left=0.02, right=0.95, bottom=0.03, top=0.91, wspace=0.05, hspace=0.12)
    fig.suptitle(f"{title} — paper 000 Fig. 5: trajectory in the target frame T".lstrip(" —"))
    paths = []
    for column, (i, plan) in enumerate(shown):
        R_LT = rotations_from_wxyz(plan["q_LT"])
        R_LC = rotations_from_wxyz(plan["q_LC"])
        r_T = np.einsum("kji,kj->ki", R_LT, np.asarray(plan["x"], float)[:, :3])
        R_TC = np.einsum("kji,kjl->kil", R_LT, R_LC)
        alpha = np.asarray(plan["alpha"], float)
        t = np.asarray(plan["t"], float)
        k_hull = min(worst, len(r_T) - 1)
        paths.append(r_T)
        for row, start in enumerate((0, min(tail, len(r_T) - 2))):
            ax = fig.add_subplot(2, len(shown), row * len(shown) + column + 1, projection="3d")
            if row == 0:
                ax.set_title(
                    f"{_iterate_label(i, len(iterates) - 1)}\nmin alpha_k = {alpha.min():.3f} "
                    f"at t = {t[int(np.argmin(alpha))]:.0f} s",
                    fontsize=10,
                )
            else:
                ax.set_title(f"zoom: knots from t = {t[start]:.0f} s", fontsize=10)
            _draw_hull(ax, V_t, np.eye(3), np.zeros(3), _TARGET_COLOUR, 0.35)
            _cone_lines(ax, np.eye(3), D_t, D_t, theta, 4.0, "tab:green")
            _draw_hull(ax, V_c, R_TC[k_hull], r_T[k_hull], _CHASER_COLOUR, 0.25)
            _draw_hull(ax, V_c, R_TC[-1], r_T[-1], _CHASER_COLOUR, 0.12)
            ax.plot(*r_T[start:].T, ".-", ms=3, color="tab:purple", lw=1.5, label="r_k in T")
            if start == 0:
                ax.plot(*r_T[:1].T, "o", color="tab:green", label="start")
            ax.plot(*r_T[-1:].T, "s", color="k", label="final knot")
            bad = alpha <= 1.0
            if bad.any():
                ax.plot(*r_T[bad].T, "x", color="tab:red", ms=7, mew=2, label="alpha_k <= 1")
            ax.plot(
                *r_T[k_hull : k_hull + 1].T,
                "o",
                mfc="none",
                mec="tab:blue",
                ms=10,
                mew=1.5,
                label=f"chaser hull at t = {t[k_hull]:.0f} s",
            )
            ax.set_xlabel("x_T [m]")
            ax.set_ylabel("y_T [m]")
            ax.set_zlabel("z_T [m]")
            if row == 0:
                ax.legend(loc="upper left", fontsize=8)
    boxes = [[V_t, *paths], [V_t, *(p[min(tail, len(p) - 2) :] for p in paths)]]
    for index, ax in enumerate(fig.axes):  # made column by column: the same box in each row
        equal_aspect_3d(ax, np.vstack(boxes[index % 2]))
    return fig


def _figure_scp_thrust(iterates: Sequence[Mapping], title: str) -> Figure:
    first, last = iterates[0], iterates[-1]
    shown = [(0, first)] + ([(len(iterates) - 1, last)] if len(iterates) > 1 else [])
    fig = Figure(figsize=(10.0, 2.6 * (len(shown) + 1)))
    axes = fig.subplots(len(shown) + 1, 1, sharex=True)
    fig.suptitle(f"{title} — paper 000 Fig. 6: thrust profile".lstrip(" —"))
    colours = _iterate_colours(len(iterates))
    for ax, (i, plan) in zip(axes, shown):
        u = np.asarray(plan["u"], float)
        t = np.asarray(plan["t"], float)
        for c, name in enumerate("xyz"):
            ax.stairs(u[:, c], t, color=_COMPONENT_COLOURS[c], label=f"u_{name} (L)")
        ax.set_title(_iterate_label(i, len(iterates) - 1), fontsize=10)
        ax.set_ylabel("force [N]")
        ax.legend(fontsize=8, ncol=3, loc="upper center")
        ax.grid(alpha=0.3)
    for i, plan in shown:
        u = np.asarray(plan["u"], float)
        axes[-1].stairs(
            np.linalg.norm(u, axis=1),
            np.asarray(plan["t"], float),
            color=colours[i],
            lw=1.5 if i else 2.5,
            label=f"|u_k|, {_iterate_label(i, len(iterates) - 1)}",
        )
    axes[-1].axhline(float(last["U_max"]), color="tab:red", ls="--", label="U_max (9)")
    axes[-1].set_ylabel("|u| [N]")
    axes[-1].set_xlabel("t [s]")
    axes[-1].legend(fontsize=8)
    axes[-1].grid(alpha=0.3)
    return fig


def _figure_scp_alpha(iterates: Sequence[Mapping], title: str) -> Figure:
    last = iterates[-1]
    fig = Figure(figsize=(13.0, 5.0))
    axes = fig.subplots(1, 2, gridspec_kw={"width_ratios": (3, 2)})
    fig.suptitle(f"{title} — paper 000 Fig. 7: alpha_k of each iterate".lstrip(" —"))
    colours = _iterate_colours(len(iterates))
    alpha_min = float(last["alpha_min"])
    first_alpha = np.asarray(iterates[0]["alpha"], float)
    zoom_from = _tail_start(first_alpha, alpha_min)
    for ax, start in zip(axes, (0, zoom_from)):
        for i, plan in enumerate(iterates):
            t = np.asarray(plan["t"], float)[start:]
            alpha = np.asarray(plan["alpha"], float)[start:]
            ax.plot(
                t,
                alpha,
                "o-",
                ms=3 if i else 4,
                lw=1.2,
                color=colours[i],
                label=_iterate_label(i, len(iterates) - 1) + f": min {alpha.min():.3f}",
            )
        ax.axhline(1.0, color="tab:red", ls="-", label="alpha = 1 (contact, hard test)")
        ax.axhline(alpha_min, color="tab:orange", ls="--", label=f"alpha_min = {alpha_min:g}")
        ax.set_xlabel("t [s]")
        ax.set_ylabel("alpha_k")
        ax.grid(alpha=0.3, which="both")
    if np.all(first_alpha > 0):
        _plain_log_y(axes[0])
    axes[0].set_title("all knots (log scale)", fontsize=10)
    axes[1].set_title(f"knots from t = {np.asarray(last['t'])[zoom_from]:.0f} s", fontsize=10)
    axes[0].legend(fontsize=8)
    return fig


def write_scp_correction_plots(
    iterates: Sequence[Mapping], out_dir: Path, title: str = ""
) -> list[Path]:
    """Writes Figs. 5-7 of paper 000 (`SCP_FIGURE_NAMES`): Problem 2 against the SCP's plan.

    Args:
        iterates: Plans at one N, in order: Problem 2's solution, then the iterate after each SCP
            iteration; the last is the planner's plan. Each holds the arrays of plan.npz that
            `FIGURES` read (t, x, u, q_LT, q_LC, alpha); the last also V_target,
            V_chaser, D_t, theta_dock, U_max and alpha_min.
        out_dir: Output folder (created if needed).
        title: Prefix of every figure's title.

    Returns:
        The paths written, in `SCP_FIGURE_NAMES` order.

    Raises:
        ValueError: No iterates, or an iterate with fewer than two knots.
    """
    _check_iterates(iterates)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name, make in zip(
        SCP_FIGURE_NAMES, (_figure_scp_trajectory, _figure_scp_thrust, _figure_scp_alpha)
    ):
        save_figure(make(iterates, title), out_dir / name)
        written.append(out_dir / name)
    return written


def write_start_outcomes_plot(
    path: Path,
    range_m: Sequence[float],
    tumble_deg_s: Sequence[float],
    statuses: Sequence[str],
    title: str = "",
) -> Path:
    """Writes paper 000's Fig. 8: each sampled start's tumble rate against its range, coloured by
    the planner's status ("success" green, every other status its own colour and marker, the
    count of each in the legend).

    Raises:
        ValueError: No starts, or inputs of different lengths.
    """
    range_m = np.asarray(range_m, float)
    tumble_deg_s = np.asarray(tumble_deg_s, float)
    statuses = [str(s) for s in statuses]
    if not len(statuses):
        raise ValueError("no starts to draw")
    if not len(range_m) == len(tumble_deg_s) == len(statuses):
        raise ValueError(
            f"range_m, tumble_deg_s, statuses: lengths {len(range_m)}, {len(tumble_deg_s)}, "
            f"{len(statuses)} differ"
        )
    order = sorted(set(statuses), key=lambda s: (s != "success", s))
    fig = Figure(figsize=(9.0, 6.0))
    ax = fig.subplots()
    fig.suptitle(title or "Paper 000 Fig. 8: outcome of each sampled start", fontsize=11)
    failures = iter(_STATUS_STYLES * (1 + len(order) // len(_STATUS_STYLES)))
    for status in order:
        colour, marker = ("tab:green", "o") if status == "success" else next(failures)
        chosen = np.array([s == status for s in statuses])
        ax.scatter(
            range_m[chosen],
            tumble_deg_s[chosen],
            s=22 if status == "success" else 70,
            c=colour,
            marker=marker,
            alpha=0.75 if status == "success" else 1.0,  # the few failures stand out
            edgecolors="none",
            zorder=2 if status == "success" else 3,
            label=f"{status}: {int(chosen.sum())}",
        )
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("start range |p_LC_L| [m]")
    ax.set_ylabel("tumble rate |w_IT_T| [deg/s]")
    ax.legend(
        fontsize=9, loc="upper left", bbox_to_anchor=(1.01, 1.0), title=f"{len(statuses)} starts"
    )
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path)
    return path


def write_alpha_overlay_plot(
    path: Path,
    trajectories: Sequence[tuple[Sequence[float], Sequence[float]]],
    alpha_min: float,
    title: str = "",
    colour_values: Sequence[float] | None = None,
    colour_label: str = "",
    labels: Sequence[str] | None = None,
) -> Path:
    """Writes paper 000's Fig. 9: alpha_k against t of every plan given, with alpha = 1 (the hard
    test) and alpha_min (the soft buffer); the least alpha_k over all plans is marked and given
    in the legend.

    Args:
        path: The PNG to write.
        trajectories: (t (N,), alpha (N,)) of each plan.
        alpha_min: The soft margin alpha_min (> 1).
        title: The figure's title.
        colour_values: Optional value per plan (e.g. its start range); lines are coloured by it
            on a colour bar labelled colour_label.
        labels: Optional name per plan (e.g. "start 17"), used to say which plan has the least
            alpha_k (default: "plan i", its index in trajectories).

    Raises:
        ValueError: No plans, a plan whose t and alpha differ in length or are empty, or
            colour_values or labels of another length.
    """
    if not len(trajectories):
        raise ValueError("no plans to draw")
    pairs = [(np.asarray(t, float), np.asarray(a, float)) for t, a in trajectories]
    for i, (t, a) in enumerate(pairs):
        if not len(t) or t.shape != a.shape:
            raise ValueError(f"plan {i}: t and alpha must be non-empty and of one length")
    labels = [f"plan {i}" for i in range(len(pairs))] if labels is None else list(labels)
    if len(labels) != len(pairs):
        raise ValueError(f"labels: {len(labels)} labels for {len(pairs)} plans")
    fig = Figure(figsize=(10.0, 6.0))
    ax = fig.subplots()
    fig.suptitle(title or "Paper 000 Fig. 9: alpha_k of every plan", fontsize=11)
    if colour_values is not None:
        values = np.asarray(colour_values, float)
        if len(values) != len(pairs):
            raise ValueError(f"colour_values: {len(values)} values for {len(pairs)} plans")
        norm = matplotlib.colors.Normalize(values.min(), max(values.max(), values.min() + 1e-9))
        # viridis without its palest yellows, which vanish on white at this line width
        cmap = matplotlib.colors.ListedColormap(
            matplotlib.colormaps["viridis"](np.linspace(0.0, 0.85, 256))
        )
        colours = [cmap(norm(v)) for v in values]
        bar = fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax)
        bar.set_label(colour_label)
    else:
        colours = ["tab:blue"] * len(pairs)
    for (t, a), colour in zip(pairs, colours):
        ax.plot(t, a, "-", lw=0.7, alpha=0.7, color=colour)
    least = min(range(len(pairs)), key=lambda i: pairs[i][1].min())
    t_least, a_least = pairs[least]
    k = int(np.argmin(a_least))
    ax.plot(
        t_least[k],
        a_least[k],
        "o",
        mfc="none",
        mec="k",
        ms=9,
        label=f"least alpha_k = {a_least[k]:.4f} ({labels[least]}, t = {t_least[k]:.0f} s)",
    )
    ax.axhline(1.0, color="tab:red", lw=1.5, label="alpha = 1 (contact, hard test)")
    ax.axhline(alpha_min, color="tab:orange", ls="--", lw=1.5, label=f"alpha_min = {alpha_min:g}")
    if all(a.min() > 0 for _, a in pairs):
        _plain_log_y(ax)
    ax.set_xlabel("t [s] from the plan's start")
    ax.set_ylabel("alpha_k")
    ax.legend(fontsize=9, loc="upper right", title=f"{len(pairs)} plans")
    ax.grid(alpha=0.3, which="both")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    save_figure(fig, path)
    return path
