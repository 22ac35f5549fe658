"""PNG figures of paper 003's planar approach (Sec. V, Figs. 4-9), from a run's log or a campaign.

Owns: the run figures `figure_planar_path`, `figure_planar_thrusters`, `figure_planar_tracking`
and `figure_planar_relative_velocity` (`run_figures()`, which the plug-in's `run_figures()` hands
rpod.diagrams.plots.write_plots), `square_corners` (a square's outline at a pose), and the
campaign maps `write_campaign_maps` (Figs. 8-9-like, over the ok runs' metrics). Does not own:
the model (rpod.models.planar_approach), the log (the planar_approach plug-in), nor writing the
run's files (plots.write_plots: atomic saves, stale files removed, a figure that fails only
warns, shapes checked by `plots.RunLog` against the generic shapes and the plug-in's
`log_shapes`).

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

Campaign maps (`write_campaign_maps`, for `rpod report` and the benchmark; rows are the ok runs'
metrics, i.e. summary.json dicts): for a campaign over omega_target and F_thr (Case Study 1)
`planar_case1.png` (Fig. 8: stacked shares of the three terms of J (eq. 5) per omega, averaged
over F_thr, with the mean +- std of the planned final position error) and heat maps of the
planned final position error, the flown RMS tracking error and the safe runs (planned, no
contact) over the grid; for one over theta_approach and omega (Case Study 2) `planar_case2.png`
(Fig. 9: a polar plot of the planned final error against theta_approach, one series per omega,
and the same heat maps over (theta_approach, omega)). A cell with no ok run is blank.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from rpod.diagrams.plots import DPI, RunLog, figure_title, has_finite, save_figure
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


# ------------------------------------------------------------------------------ campaigns


def _values(metrics: list[dict], key: str) -> np.ndarray:
    return np.array(
        [m.get(key) if m.get(key) is not None else np.nan for m in metrics], dtype=float
    )


def _grid_image(x: np.ndarray, y: np.ndarray, z: np.ndarray, reduce=np.nanmean):
    """(x values, y values, image (len(y), len(x))) of z over the distinct (x, y) pairs."""
    xs, ys = np.unique(np.round(x, 6)), np.unique(np.round(y, 6))
    image = np.full((len(ys), len(xs)), np.nan)
    for j, yv in enumerate(ys):
        for i, xv in enumerate(xs):
            cell = z[(np.round(x, 6) == xv) & (np.round(y, 6) == yv)]
            cell = cell[np.isfinite(cell)]
            if cell.size:
                image[j, i] = reduce(cell)
    return xs, ys, image


def _edges(values: np.ndarray) -> np.ndarray:
    if len(values) == 1:
        return np.array([values[0] - 0.5, values[0] + 0.5])
    mid = 0.5 * (values[1:] + values[:-1])
    return np.r_[2 * values[0] - mid[0], mid, 2 * values[-1] - mid[-1]]


def _heat(fig, ax, x, y, z, xlabel, ylabel, label, cmap="viridis", reduce=np.nanmean):
    xs, ys, image = _grid_image(x, y, z, reduce)
    mesh = ax.pcolormesh(_edges(xs), _edges(ys), image, cmap=cmap, shading="flat")
    fig.colorbar(mesh, ax=ax, label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)


def write_campaign_maps(metrics: list[dict], out_dir) -> list[Path]:
    """Writes planar_case1.png and/or planar_case2.png (module docstring); returns the paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    metrics = [m for m in metrics if "planar_plan_status" in m]
    if not metrics:
        return []
    omega = _values(metrics, "planar_omega_target_rad_s")
    thrust = _values(metrics, "planar_thrust_N")
    theta = _values(metrics, "planar_theta_approach_deg")
    final = _values(metrics, "planar_plan_terminal_position_error_m")
    rms = _values(metrics, "planar_rms_tracking_error_m")
    safe = np.array([bool(m.get("planar_safe")) for m in metrics], dtype=float)
    paths = []
    if len(np.unique(np.round(theta, 6))) > 1:
        fig = Figure(figsize=(16, 4.8), dpi=DPI)
        polar = fig.add_subplot(1, 4, 1, projection="polar")
        cmap = colormaps["plasma"]
        omegas = np.unique(np.round(omega, 6))
        for k, value in enumerate(omegas):
            mask = np.round(omega, 6) == value
            order = np.argsort(theta[mask])
            angles = np.radians(theta[mask][order])
            radii = final[mask][order]
            polar.plot(
                np.r_[angles, angles[:1]],
                np.r_[radii, radii[:1]],
                "-o",
                ms=2,
                lw=0.7,
                color=cmap(k / max(len(omegas) - 1, 1)),
            )
        polar.set_title("planned final position error [m]\nvs theta_approach (Fig. 9)", fontsize=9)
        for index, (z, label, reduce) in enumerate(
            (
                (final, "planned final position error [m]", np.nanmean),
                (rms, "flown RMS tracking error [m]", np.nanmean),
                (safe, "safe share (planned, no contact)", np.nanmean),
            )
        ):
            ax = fig.add_subplot(1, 4, index + 2)
            _heat(
                fig,
                ax,
                theta,
                omega,
                z,
                "theta_approach [deg]",
                "omega_target [rad/s]",
                label,
                reduce=reduce,
            )
        fig.suptitle(
            f"Case Study 2 ({len(metrics)} runs; polar: one series per omega, dark = slow)",
            fontsize=10,
        )
        fig.tight_layout()
        path = out_dir / "planar_case2.png"
        save_figure(fig, path)
        paths.append(path)
    elif len(np.unique(np.round(omega, 6))) > 1:
        fig = Figure(figsize=(16, 9), dpi=DPI)
        ax = fig.add_subplot(2, 2, 1)
        omegas = np.unique(np.round(omega, 6))
        terms = {
            name: _values(metrics, f"planar_plan_cost_{name}")
            for name in ("goal", "control", "kinetic")
        }
        total = sum(np.nan_to_num(v) for v in terms.values())
        bottom = np.zeros(len(omegas))
        width = 0.8 * (np.min(np.diff(omegas)) if len(omegas) > 1 else 0.1)
        for name, colour in (
            ("goal", "tab:red"),
            ("control", "tab:blue"),
            ("kinetic", "tab:green"),
        ):
            with np.errstate(invalid="ignore", divide="ignore"):
                share = np.where(total > 0, terms[name] / total, np.nan)
            mean = np.array(
                [
                    np.nanmean(share[np.round(omega, 6) == w])
                    if np.any(np.isfinite(share[np.round(omega, 6) == w]))
                    else 0.0
                    for w in omegas
                ]
            )
            ax.bar(
                omegas,
                mean,
                width,
                bottom=bottom,
                color=colour,
                alpha=0.6,
                label=f"{name} term share",
            )
            bottom += mean
        ax.set_ylim(0.0, 1.05)
        ax.set_xlabel("omega_target [rad/s]")
        ax.set_ylabel("share of J (eq. 5), mean over F_thr")
        twin = ax.twinx()
        mean = [
            np.nanmean(final[(np.round(omega, 6) == w) & np.isfinite(final)])
            if np.any(np.isfinite(final[np.round(omega, 6) == w]))
            else np.nan
            for w in omegas
        ]
        std = [
            np.nanstd(final[(np.round(omega, 6) == w) & np.isfinite(final)])
            if np.any(np.isfinite(final[np.round(omega, 6) == w]))
            else np.nan
            for w in omegas
        ]
        twin.errorbar(
            omegas,
            mean,
            yerr=std,
            fmt="o-",
            color="k",
            ms=3,
            lw=1.0,
            capsize=2,
            label="planned final position error (mean +- std)",
        )
        twin.set_ylabel("final position error [m]")
        ax.legend(loc="upper left", fontsize=7)
        twin.legend(loc="upper right", fontsize=7)
        ax.set_title("Case Study 1 (Fig. 8)", fontsize=10)
        for index, (z, label) in enumerate(
            (
                (final, "planned final position error [m]"),
                (rms, "flown RMS tracking error [m]"),
                (safe, "safe share (planned, no contact)"),
            )
        ):
            ax = fig.add_subplot(2, 2, index + 2)
            _heat(fig, ax, omega, thrust, z, "omega_target [rad/s]", "F_thr [N]", label)
        fig.suptitle(f"Case Study 1 ({len(metrics)} runs)", fontsize=10)
        fig.tight_layout()
        path = out_dir / "planar_case1.png"
        save_figure(fig, path)
        paths.append(path)
    return paths
