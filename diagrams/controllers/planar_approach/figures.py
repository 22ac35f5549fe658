"""PNG figures of paper 003's planar approach (Sec. V, Figs. 4-7), from a run's log.

Owns: the run figures `figure_planar_path`, `figure_planar_thrusters`, `figure_planar_tracking`
and `figure_planar_relative_velocity` and their `run_figures()`, which the plug-in hands
rpod.diagrams.plots.write_plots, and `square_corners` (a square's outline at a pose). Does not
own: the model (rpod.models.planar_approach), the log (metrics.py), the campaign maps
(campaign_maps.py), nor writing the run's files (plots.write_plots: atomic saves, stale files
removed, a figure that fails only warns, shapes checked by `plots.RunLog` against the generic
shapes and the plug-in's `log_shapes`, plugin.py).

Log keys (N samples, time first; all drawn only when planar_flown_state is logged; in L):
  planar_flown_state (N, 6)         the truth's x = [x, y, theta, v_x, v_y, omega] (eq. 1).
  planar_plan_state (N, 6)          the plan's x at each sample, NaN outside [0, T].
  planar_position_error_m (N)       |p - p_plan| [m], NaN outside [0, T].
  planar_attitude_error_rad (N)     theta - the tracked heading, wrapped [rad].
  planar_target_yaw_rad (N)         the target's attitude theta_t [rad].
  planar_relative_velocity_T (N, 2) the chaser's velocity seen and expressed in T [m/s].
  planar_keepout_state (N)          the KOS state at the chaser's centre (1: State I, 2: II).
  planar_keepout_q_m (N)            q of eq. 9 there [m] (< 0 inside the zone).
  planar_goal_L (N, 2)              x_goal of eq. 5 [m].
  planar_chaser_side_m (N), planar_target_side_m (N)  the squares' sides [m].
  planar_body_wrench_desired (N, 6) the tracker's [tau_C; f_C] (eq. 13) [N m, N].
  thruster_on (N, 8)                the thrusters' ON/OFF (PWM output).

Figures:
  planar_path.png               (Fig. 4) the flown path (solid) and the plan (dotted) in L, the
                                chaser and the target drawn as squares at 10 instants (colour
                                = time), the docking face of each target square bold, the goal,
                                and the KOS of the final instant's state (dashed) on the target.
  planar_thrusters.png          (Fig. 5) (a) each thruster's ON/OFF against time; (b) the
                                desired body force and torque the allocation is asked for.
  planar_tracking.png           (Fig. 6) (a) planned (dotted) against flown (solid) path;
                                (b) position error [cm] with its RMS and attitude error [deg];
                                (c) q of eq. 9 at the chaser's centre with the KOS state.
  planar_relative_velocity.png  (Fig. 7) relative velocity in T: components and norm, the
                                planned arrival and the paper's ~0.03 m/s.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from rpod.diagrams.plots import DPI, RunLog, figure_title, has_finite
from rpod.models import planar_approach as pa

_INSTANTS = 10  # squares drawn along the path (Fig. 4)
_PAPER_RELATIVE_SPEED_M_S = 0.03  # Sec. V-C: "converges to approximately 0.03 m/s"
_STATE_COLOURS = {pa.STATE_I: "tab:red", pa.STATE_II: "tab:green"}


FIGURE_NAMES = (
    "planar_path.png",
    "planar_thrusters.png",
    "planar_tracking.png",
    "planar_relative_velocity.png",
)


def run_figures() -> dict:
    """The planar approach's run figures: {file name: draw(log, title)} (read when called, so a patched figure is drawn)."""
    return dict(
        zip(
            FIGURE_NAMES,
            (
                figure_planar_path,
                figure_planar_thrusters,
                figure_planar_tracking,
                figure_planar_relative_velocity,
            ),
        )
    )


def _plane_axes(ax, title: str) -> None:
    """The plane in L at equal scale, labelled, gridded, with its legend and title."""
    ax.set_aspect("equal")
    ax.set_xlabel("x_L [m]")
    ax.set_ylabel("y_L [m]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title, fontsize=10)


def square_corners(centre, yaw: float, side: float) -> np.ndarray:
    """The closed outline (5, 2) of a square of `side` centred at `centre`, turned by `yaw`."""
    h = 0.5 * side
    local = np.array([[h, h], [-h, h], [-h, -h], [h, -h], [h, h]])
    c, s = math.cos(yaw), math.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + np.asarray(centre, float)


def _rotate(points: np.ndarray, yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return points @ np.array([[c, s], [-s, c]])


def _arrival_s(log: RunLog) -> float | None:
    """The planned arrival: the last sample with a plan state."""
    plan = log.get("planar_plan_state")
    if plan is None:
        return None
    finite = np.flatnonzero(np.isfinite(plan[:, 0]))
    return float(log.t[finite[-1]]) if len(finite) else None


def _sides(log: RunLog) -> tuple[float, float]:
    chaser, target = log.get("planar_chaser_side_m"), log.get("planar_target_side_m")
    return (
        float(chaser[0]) if chaser is not None else 0.3,
        float(target[0]) if target is not None else 0.3,
    )


def _keepout_outline(geometry: pa.KeepOutGeometry, state: int) -> list[np.ndarray]:
    from rpod.systems.planar_scene import keepout_outlines_T  # the same outlines as the scene

    return [np.vstack([p, p[:1]]) for p in keepout_outlines_T(geometry, state)]


def figure_planar_path(log: RunLog, title: str) -> Figure | None:
    """Fig. 4: the path with the two squares' poses in L."""
    flown = log.get("planar_flown_state")
    if not has_finite(flown):
        return None
    t = log.t
    plan = log.get("planar_plan_state")
    yaw_t = log.get("planar_target_yaw_rad")
    chaser_side, target_side = _sides(log)
    fig = Figure(figsize=(7.5, 7.0), dpi=DPI)
    ax = fig.add_subplot()
    ax.plot(flown[:, 0], flown[:, 1], "-", color="tab:blue", lw=1.2, label="flown")
    if has_finite(plan):
        ax.plot(plan[:, 0], plan[:, 1], ":", color="k", lw=1.2, label="planned")
    arrival = _arrival_s(log)
    end = t[-1] if arrival is None else min(arrival, t[-1])
    instants = np.linspace(t[0], end, _INSTANTS)
    cmap = colormaps["viridis"]
    for k, when in enumerate(instants):
        i = int(min(np.searchsorted(t, when), len(t) - 1))
        colour = cmap(k / max(_INSTANTS - 1, 1))
        square = square_corners(flown[i, :2], flown[i, 2], chaser_side)
        ax.plot(square[:, 0], square[:, 1], "-", color=colour, lw=1.0)
        ax.plot(*square[[0, 3]].T, "-", color=colour, lw=2.5)  # the docking face +x_C
        if yaw_t is not None:
            target = square_corners((0.0, 0.0), yaw_t[i], target_side)
            ax.plot(target[:, 0], target[:, 1], "--", color=colour, lw=0.8)
            ax.plot(*target[[0, 3]].T, "-", color=colour, lw=2.0)  # the docking face +x_T
    goal = log.get("planar_goal_L")
    if goal is not None:
        ax.plot(*goal[0], "*", color="tab:red", ms=12, label="goal x_goal (eq. 5)")
    state = log.get("planar_keepout_state")
    if yaw_t is not None and state is not None:
        i = int(min(np.searchsorted(t, end), len(t) - 1))
        geometry = pa.KeepOutGeometry(chaser_side, target_side)
        for k, outline in enumerate(_keepout_outline(geometry, int(state[i]))):
            xy = _rotate(outline, yaw_t[i])
            ax.plot(
                xy[:, 0],
                xy[:, 1],
                "--",
                color=_STATE_COLOURS.get(int(state[i]), "0.5"),
                lw=0.8,
                label=f"KOS State {'I' * int(state[i])} at {t[i]:.1f} s" if k == 0 else None,
            )
    ax.plot(flown[0, 0], flown[0, 1], "o", color="tab:green", ms=6, label="start")
    sm = colormaps["viridis"].resampled(_INSTANTS)
    mappable = ScalarMappable(norm=Normalize(instants[0], instants[-1]), cmap=sm)
    fig.colorbar(mappable, ax=ax, label="t [s] of the squares (bold side: docking face)")
    _plane_axes(ax, figure_title(title, "path and poses (Fig. 4)"))
    return fig


def figure_planar_thrusters(log: RunLog, title: str) -> Figure | None:
    """Fig. 5: the thrusters' ON/OFF sequence and the desired body wrench."""
    if log.get("planar_flown_state") is None:
        return None
    on = log.get("thruster_on")
    wrench = log.get("planar_body_wrench_desired")
    if not has_finite(on) and not has_finite(wrench):
        return None
    t = log.t
    panels = [p for p in (on, wrench) if has_finite(p)]
    fig = Figure(figsize=(10, 2.8 * len(panels) + 0.6), dpi=DPI)
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)[:, 0]
    k = 0
    if has_finite(on):
        ax = axes[k]
        k += 1
        n = on.shape[1]
        edges = np.r_[t, t[-1] + (t[-1] - t[-2] if len(t) > 1 else 1.0)]
        ax.pcolormesh(
            edges,
            np.arange(n + 1) - 0.5,
            (on.T > 0.5).astype(float),
            cmap="Greys",
            vmin=0.0,
            vmax=1.0,
            shading="flat",
            rasterized=True,
        )
        ax.set_ylim(n - 0.5, -0.5)
        ax.set_yticks(np.arange(n))
        ax.set_ylabel("thruster k (black: ON)")
        fraction = float(np.mean(on > 0.5))
        ax.set_title(
            figure_title(title, f"thruster ON/OFF (Fig. 5); ON {100 * fraction:.1f}% of the time"),
            fontsize=10,
        )
    if has_finite(wrench):
        ax = axes[k]
        for index, name, colour in ((3, "f_x", "tab:red"), (4, "f_y", "tab:green")):
            ax.plot(t, wrench[:, index], color=colour, lw=0.8, label=f"{name} [N]")
        twin = ax.twinx()
        twin.plot(t, wrench[:, 2], color="tab:blue", lw=0.8, label="tau_z [N m]")
        twin.set_ylabel("tau_z [N m]", color="tab:blue")
        ax.set_ylabel("force in C [N]")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
        twin.legend(loc="upper right", fontsize=8)
        ax.set_title("desired body wrench (eq. 13), the allocation's input (eq. 14)", fontsize=9)
    axes[-1].set_xlabel(log.t_label)
    fig.tight_layout()
    return fig


def figure_planar_tracking(log: RunLog, title: str) -> Figure | None:
    """Fig. 6: planned against flown path, and the errors."""
    flown, plan = log.get("planar_flown_state"), log.get("planar_plan_state")
    if not has_finite(flown):
        return None
    t = log.t
    fig = Figure(figsize=(12, 6.5), dpi=DPI)
    grid = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.4))
    ax = fig.add_subplot(grid[:, 0])
    ax.plot(flown[:, 0], flown[:, 1], "-", color="tab:blue", lw=1.2, label="flown")
    if has_finite(plan):
        ax.plot(plan[:, 0], plan[:, 1], ":", color="k", lw=1.5, label="planned (ideal)")
    ax.plot(0.0, 0.0, "+", color="k", ms=10)
    _plane_axes(ax, figure_title(title, "planned vs flown (Fig. 6)"))
    error, attitude = log.get("planar_position_error_m"), log.get("planar_attitude_error_rad")
    ax = fig.add_subplot(grid[0, 1])
    if has_finite(error):
        rms = float(np.sqrt(np.nanmean(error**2)))
        ax.plot(t, 100.0 * error, color="tab:blue", lw=0.8, label="|p - p_plan|")
        ax.axhline(100.0 * rms, color="tab:blue", ls="--", lw=0.8, label=f"RMS {100 * rms:.2f} cm")
        ax.set_ylabel("position error [cm]")
        ax.legend(loc="upper left", fontsize=8)
    if has_finite(attitude):
        twin = ax.twinx()
        twin.plot(t, np.degrees(attitude), color="tab:orange", lw=0.8)
        twin.set_ylabel("attitude error [deg]", color="tab:orange")
    ax.grid(True, alpha=0.3)
    ax.set_title("tracking error (eq. 11), over the planned span", fontsize=9)
    ax = fig.add_subplot(grid[1, 1], sharex=ax)
    q, state = log.get("planar_keepout_q_m"), log.get("planar_keepout_state")
    if has_finite(q):
        ax.plot(t, q, color="k", lw=0.8, label="q (eq. 9) at the chaser's centre")
        ax.axhline(0.0, color="tab:red", lw=0.8)
    if state is not None:
        for code, colour in _STATE_COLOURS.items():
            mask = state == code
            if np.any(mask):
                low, high = ax.get_ylim() if has_finite(q) else (0.0, 1.0)
                ax.fill_between(
                    t,
                    low,
                    high,
                    where=mask,
                    color=colour,
                    alpha=0.12,
                    step="post",
                    label=f"State {'I' * code}",
                )
    separation = log.get("separation_m")
    if has_finite(separation):
        ax.plot(t, separation, color="tab:purple", lw=0.8, label="true separation")
    ax.set_ylabel("[m]")
    ax.set_xlabel(log.t_label)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    return fig


def figure_planar_relative_velocity(log: RunLog, title: str) -> Figure | None:
    """Fig. 7: the chaser's velocity relative to the target, in the target frame."""
    v = log.get("planar_relative_velocity_T")
    if not has_finite(v):
        return None
    t = log.t
    fig = Figure(figsize=(9, 4.2), dpi=DPI)
    ax = fig.add_subplot()
    ax.plot(t, v[:, 0], color="tab:red", lw=0.8, label="v_x_T")
    ax.plot(t, v[:, 1], color="tab:green", lw=0.8, label="v_y_T")
    ax.plot(t, np.linalg.norm(v, axis=1), color="k", lw=1.2, label="|v_rel|")
    ax.axhline(_PAPER_RELATIVE_SPEED_M_S, color="0.5", ls="--", lw=0.8, label="paper: ~0.03 m/s")
    arrival = _arrival_s(log)
    if arrival is not None:
        i = int(min(np.searchsorted(t, arrival), len(t) - 1))
        speed = float(np.linalg.norm(v[i]))
        ax.axvline(arrival, color="tab:blue", ls=":", lw=1.0)
        ax.annotate(
            f"arrival {arrival:.1f} s: {speed:.4f} m/s",
            (arrival, speed),
            xytext=(-10, 20),
            textcoords="offset points",
            ha="right",
            fontsize=8,
            arrowprops={"arrowstyle": "->", "lw": 0.6},
        )
    ax.set_xlabel(log.t_label)
    ax.set_ylabel("relative velocity in T [m/s]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(figure_title(title, "chaser-target relative velocity in T (Fig. 7)"), fontsize=10)
    return fig
