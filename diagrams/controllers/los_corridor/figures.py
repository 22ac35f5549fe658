"""PNG figures of paper 004's rotating-LOS-corridor guidance (Secs. 5-7), from a run's log.

Owns: the figure functions `figure_los_corridor` and `figure_los_body_frame` and their
`run_figures()`, which the plug-in hands rpod.diagrams.plots.write_plots; `section_slopes` (the
corridor's sections through its axis, as drawn). Does not own: the corridor
(rpod.models.los_corridor), the guidance, the log or `violation_summary` (metrics.py), nor
writing the files (plots.write_plots: atomic saves, stale files removed, a figure that fails
only warns, shapes checked by `plots.RunLog` against the generic shapes and the plug-in's
`log_shapes`, plugin.py).

Log keys (N samples, time first; any may be missing; in L unless named otherwise):
  los_range_m (N)              |p_TC| [m].
  los_sync_range_m (N)         r_sync = 2 a_max / omega_t^2 (eq. 14) [m].
  los_hold_point_T (N, 3)      the hold point H in T [m].
  los_R_TK (N, 9)              the corridor's frame K in T, row-major, when its axis is not
                               +y_T (`corridor_axis: docking`): los_body_frame.png is then
                               drawn in K (its +y the docking axis).
  los_face_distance_m (N, n_f + 1)  signed distance to each corridor plane, faces 1..n_f then
                               the floor, positive inside [m] (n_f = 8 in paper 004; >= 3).
  los_command_L (N, 3)         the command the guidance applied (MPC u_0 or a fallback) [m/s^2].
  los_nominal_L (N, 3)         the PD command before the MPC filter (Sec. 7) [m/s^2].
  los_applied_L (N, 3)         the acceleration the truth received [m/s^2].
  los_regime (N)               0 far approach, 1 close approach, 2 hold (Sec. 7).
  los_mpc_status (N)           0 solved, 1 solved inaccurate, 2 primal infeasible, 3 dual
                               infeasible, 4 max iterations, 5 other, -1 not solved yet.
  los_fallback (N)             0 MPC input applied, 1 shifted previous plan, 2 brake, 3 the
                               far approach's own command, 4 the best-effort QP's input
                               (rpod.systems.los_guidance.Fallback).
  los_a_max_m_s2 (N)           the input bound a_max (eq. 11e) [m/s^2].
  los_half_angle_deg (N)       the corridor half-angle alpha_c [deg].

Figures:
  los_corridor.png    (a) range with r_sync, the hold range |p_TH| and the regime as background
                      bands; (b) distance to each face and the floor, the least of them bold,
                      violations in red with the worst one's depth and the time in violation;
                      (c) applied (solid), commanded (dashed) and nominal PD (dotted) acceleration
                      per component with +-a_max; (d) MPC status and fallback as colour strips,
                      with a marker at the start of every failure or fallback.
  los_body_frame.png  the path in T on the x_T-y_T and z_T-y_T planes with the corridor's wedge,
                      floor, hold point, start and end, and the violating samples in red.

Decisions:
- A figure is drawn only for a run that logged a usable los_* key: the body-frame path alone
  (any run with q_IT) does not make a LOS figure. A panel without data is omitted.
- Violation: as metrics.py counts it (`violation_summary`: the least distance over the n_f + 1
  planes below -1e-3 m, paper 004 Sec. 9's tolerance); sample i drawn over [t_i, t_{i+1}), as
  the heatmaps of plots.py draw it.
- The wedge: the corridor's sections by the planes z_T = 0 and x_T = 0 (apex at T's origin,
  rpod.models.los_corridor). In the plane z_T = 0 face i reads cos(theta_i) x_T <= tan(alpha_c)
  y_T, so the section is -s_- y_T <= x_T <= s_+ y_T with s_+- = tan(alpha_c) / max_i(+-cos
  theta_i), likewise with sin theta_i for z_T (`section_slopes`): all four are tan(alpha_c) for
  n_f = 8 (faces theta = 0, pi/2, pi, 3 pi/2), wider for an n_f not divisible by 4. A point
  inside the corridor projects inside both sections; a projection inside says nothing about
  the other coordinate, so violations are marked from the logged distances, not the picture.
  alpha_c from los_half_angle_deg, else LosCorridor's default (30 deg, Table 1), marked
  "assumed". The floor's y_T from the log, the median of y_T - (floor distance) (the floor's
  normal is the unit +y_T, so its distance is y_T - y_min whatever the faces' normalisation),
  else LosCorridor's default (1 m), marked "assumed".
- Codes (regime, status, fallback) are drawn as one rectangle per run of equal consecutive
  values over its time edges (`broken_barh`), so a switch lasting one sample still shows; a
  failure or a fallback also gets a marker at its start, visible at any zoom.
- Face distances on a symlog scale when they span >= 2 decades beyond the linear band
  max(depth of the worst violation, tol, 1e-4 x the largest distance): the margins near zero,
  where the corridor matters, stay readable next to the far approach's hundreds of metres.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from rpod.diagrams.controllers.los_corridor.metrics import violation_summary
from rpod.diagrams.plots import (
    COMPONENT_COLOURS,
    DPI,
    LEGEND_OUTSIDE,
    RunLog,
    code_bands,
    code_runs,
    constant_value,
    draw_level,
    envelope,
    figure_title,
    grid,
    has_finite,
    hold_points,
    mark_start_end,
    stacked_time_figure,
)
from rpod.models.los_corridor import VIOLATION_TOLERANCE_M, LosCorridor

_logger = logging.getLogger(__name__)


FIGURE_NAMES = ("los_corridor.png", "los_body_frame.png")


def run_figures() -> dict:
    """The LOS corridor's run figures: {file name: draw(log, title)} (read when called, so a patched figure is drawn)."""
    return dict(
        zip(
            FIGURE_NAMES,
            (
                figure_los_corridor,
                figure_los_body_frame,
            ),
        )
    )


_MIN_FACES = 3  # n_f of the narrowest pyramid (LosCorridor's own bound)
_REGIMES = {
    0: ("far approach", "tab:blue"),
    1: ("close approach", "tab:orange"),
    2: ("hold", "tab:green"),
    3: ("entry (round the target)", "tab:purple"),
}
_STATUS = {
    -1: ("not solved yet", "0.8"),
    0: ("solved", "tab:green"),
    1: ("solved inaccurate", "tab:orange"),
    2: ("primal infeasible", "tab:red"),
    3: ("dual infeasible", "darkred"),
    4: ("max iterations", "tab:pink"),
    5: ("other failure", "tab:purple"),
}
_FALLBACK = {
    0: ("MPC u_0 applied", "#cfe8cf"),
    1: ("shifted previous plan", "tab:orange"),
    2: ("brake", "tab:red"),
    3: ("far-approach command", "tab:blue"),  # Fallback.NOMINAL: no braking far out
    4: ("best-effort QP (soft corridor)", "gold"),  # Fallback.BEST_EFFORT
}


# --------------------------------------------------------------------------------------------
# Computations


def _floor_y(p_TC_T: np.ndarray | None, face_distance: np.ndarray | None) -> float | None:
    """The floor's y_T [m] recovered from the log: median of y_T - (floor distance)."""
    if p_TC_T is None or face_distance is None:
        return None
    y_min = p_TC_T[:, 1] - face_distance[:, -1]
    y_min = y_min[np.isfinite(y_min)]
    return float(np.median(y_min)) if len(y_min) else None


def section_slopes(half_angle_rad: float, faces: int) -> tuple[float, float, float, float]:
    """(s_-x, s_+x, s_-z, s_+z): the corridor's sections by z_T = 0 and x_T = 0 are
    -s_-x y_T <= x_T <= s_+x y_T and -s_-z y_T <= z_T <= s_+z y_T (module docstring).

    Face i (theta_i = 2 pi (i - 1) / n_f, eq. 9) bounds u . (x_T, z_T) for a unit direction u
    by tan(alpha_c) y_T / (n_i . u), n_i = (cos theta_i, sin theta_i); the tightest face wins.
    """
    theta = 2.0 * math.pi * np.arange(faces) / faces
    normals = np.column_stack([np.cos(theta), np.sin(theta)])
    directions = np.array([[-1.0, 0.0], [1.0, 0.0], [0.0, -1.0], [0.0, 1.0]])
    reach = (normals @ directions.T).max(axis=0)  # > 0 for n_f >= 3
    s = math.tan(half_angle_rad) / reach
    return float(s[0]), float(s[1]), float(s[2]), float(s[3])


def _face_distances(log: RunLog, warn: bool = False) -> np.ndarray | None:
    """los_face_distance_m when it has n_f + 1 >= 4 columns (faces, then the floor)."""
    d = log.get("los_face_distance_m")
    if d is not None and d.shape[1] < _MIN_FACES + 1:
        if warn:
            _logger.warning(
                "plots: log['los_face_distance_m'] has %d columns, needs n_f + 1 >= %d; skipped",
                d.shape[1],
                _MIN_FACES + 1,
            )
        return None
    return d


# --------------------------------------------------------------------------------------------
# los_corridor.png


def _is_los_run(log: RunLog) -> bool:
    return any(key.startswith("los_") and has_finite(a) for key, a in log.arrays.items())


def _panel_range(ax, log: RunLog, edges) -> None:
    t = log.t
    rng, sync, hold = (
        log.get("los_range_m"),
        log.get("los_sync_range_m"),
        log.get("los_hold_point_T"),
    )
    regime = log.get("los_regime")
    hold_range = np.linalg.norm(hold, axis=1) if hold is not None else None
    if regime is not None:
        code_bands(ax, edges, regime, _REGIMES, alpha=0.13)
    if has_finite(rng):
        ax.plot(*envelope(t, rng), color="k", lw=1.2, label="range |p_TC|")
    if has_finite(sync):
        draw_level(ax, t, sync, color="tab:red", ls="--", lw=1.0, label="r_sync = 2 a_max / ω_t²")
    if has_finite(hold_range):
        draw_level(ax, t, hold_range, color="tab:purple", ls=":", lw=1.2, label="hold range |p_TH|")
    levels = [a[np.isfinite(a)] for a in (rng, sync, hold_range) if a is not None]
    values = np.concatenate(levels) if levels else np.empty(0)
    if len(values) and values.min() > 0.0 and values.max() / values.min() >= 100.0:
        ax.set_yscale("log")
    ax.set_ylabel("range [m]")
    ax.set_title("range and guidance regime (Sec. 7)", fontsize=10)
    ax.legend(**LEGEND_OUTSIDE)


def _panel_faces(ax, log: RunLog, edges) -> None:
    t, d = log.t, _face_distances(log)
    faces = d.shape[1] - 1
    least = np.fmin.reduce(d, axis=1)
    violating = least < -VIOLATION_TOLERANCE_M
    code_bands(ax, edges, violating.astype(float), {1: ("violation", "tab:red")}, alpha=0.2)
    t_env, d_env = envelope(t, d)
    colours = [colormaps["hsv"](i / faces) for i in range(faces)]  # cyclic, as theta_i
    for i in range(faces):
        ax.plot(t_env[:, i], d_env[:, i], color=colours[i], lw=0.6, alpha=0.8)
    ax.plot(t_env[:, faces], d_env[:, faces], color="tab:brown", lw=0.9, ls="--", label="floor")
    ax.plot(*envelope(t, least), color="k", lw=1.6, label="least over faces and floor")
    if violating.any():
        ax.plot(*envelope(t, np.where(violating, least, np.nan)), color="tab:red", lw=2.0)
    ax.axhline(0.0, color="k", lw=0.8, ls=":")
    depth, duration, first = violation_summary(t, d)
    unit = "s" if "t" in log.arrays else "samples"
    if first is None:
        text = f"no violation (every distance >= -{VIOLATION_TOLERANCE_M:g} m)"
    else:
        i = int(np.nanargmin(least))
        face = int(np.nanargmin(d[i]))
        where = f"face {face + 1}" if face < faces else "floor"
        runs = int(np.count_nonzero(code_runs(violating.astype(float))[0] == 1))
        text = (
            f"worst violation {depth:.3g} m ({where}) at {log.when(i)}; "
            f"{duration:.4g} {unit} in violation over {runs} interval(s), "
            f"the first at {log.when(int(np.flatnonzero(violating)[0]))}"
        )
        ax.plot(t[i], least[i], "v", color="tab:red", ms=8, zorder=5)
    finite = d[np.isfinite(d)]
    if len(finite):
        lo, hi = float(finite.min()), float(finite.max())
        linthresh = max(-min(lo, 0.0), VIOLATION_TOLERANCE_M, 1e-4 * hi)
        if hi / linthresh >= 100.0:
            ax.set_yscale("symlog", linthresh=linthresh)
    handles, labels = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], color=colours[0], lw=0.6))
    labels.append(f"faces 1..{faces} (thin)")
    ax.legend(handles, labels, **LEGEND_OUTSIDE)
    ax.set_ylabel("distance inside [m]")
    ax.set_title(f"distance to the corridor's planes, positive inside (eq. 9)\n{text}", fontsize=10)


def _panel_acceleration(ax, log: RunLog) -> None:
    t = log.t
    series = (
        ("los_applied_L", "applied to the truth", "-", 1.0, 1.0),
        ("los_command_L", "commanded (MPC u_0 or fallback)", "--", 1.0, 0.9),
        ("los_nominal_L", "nominal PD (before the filter)", ":", 0.5, 0.9),
    )
    style_handles, drawn = [], []
    for key, label, ls, alpha, lw in series:
        a = log.get(key)
        if not has_finite(a):
            continue
        drawn.append(key)
        t_env, a_env = envelope(t, a)
        for j in range(3):
            ax.plot(t_env[:, j], a_env[:, j], ls=ls, lw=lw, alpha=alpha, color=COMPONENT_COLOURS[j])
        style_handles.append(Line2D([], [], color="0.3", ls=ls, alpha=alpha, label=label))
    a_max = log.get("los_a_max_m_s2")
    bound = 0.0
    if has_finite(a_max):
        draw_level(ax, t, a_max, color="k", ls="-.", lw=0.9)
        draw_level(ax, t, -a_max, color="k", ls="-.", lw=0.9)
        bound = float(np.nanmax(np.abs(a_max)))
        style_handles.append(Line2D([], [], color="k", ls="-.", lw=0.9, label="±a_max (eq. 11e)"))
    # The nominal PD command may be far outside the bound: the view follows what was applied.
    followed = [key for key in drawn if key != "los_nominal_L"] or drawn
    extent = max([bound] + [float(np.nanmax(np.abs(log.get(key)))) for key in followed])
    if extent > 0.0:
        ax.set_ylim(-1.2 * extent, 1.2 * extent)
    component_handles = [
        Line2D([], [], color=c, lw=1.5, label=f"{name}_L")
        for c, name in zip(COMPONENT_COLOURS, "xyz")
    ]
    ax.legend(handles=component_handles + style_handles, **LEGEND_OUTSIDE)
    ax.set_ylabel("acceleration in L [m/s²]")
    ax.set_title("acceleration: applied, commanded and nominal", fontsize=10)


def _panel_status(ax, log: RunLog, edges) -> None:
    t = log.t
    rows = [
        (key, styles, failure)
        for key, styles, failure in (
            ("los_mpc_status", _STATUS, 2),
            ("los_fallback", _FALLBACK, 1),
        )
        if has_finite(log.get(key))
    ]
    names = {"los_mpc_status": "MPC status", "los_fallback": "fallback"}
    for k, (key, styles, failure) in enumerate(rows):  # the first row on top
        row = len(rows) - 1 - k
        codes = log.get(key)
        code_bands(ax, edges, codes, styles, y=(row - 0.35, row + 0.35), axes_y=False, percent=True)
        values, starts, _ = code_runs(codes)
        events = starts[values >= failure]
        ax.plot(t[events], np.full(len(events), row + 0.42), "v", color="k", ms=4, zorder=5)
    ax.set_yticks(np.arange(len(rows)))
    ax.set_yticklabels([names[key] for key, _, _ in reversed(rows)])
    ax.set_ylim(-0.6, len(rows) - 0.35)
    ax.legend(**LEGEND_OUTSIDE)
    ax.set_title("MPC status and fallback (▼: a failure or fallback starts)", fontsize=10)


def figure_los_corridor(log: RunLog, title: str) -> Figure | None:
    """los_corridor.png (module docstring), or None without any LOS data."""
    if not _is_los_run(log):
        return None

    def has(*keys: str) -> bool:
        return has_finite(*(log.get(key) for key in keys))

    panels = []  # (kind, relative height)
    if has("los_range_m", "los_sync_range_m", "los_regime", "los_hold_point_T"):
        panels.append(("range", 1.0))
    if has_finite(_face_distances(log, warn=True)):
        panels.append(("faces", 1.0))
    if has("los_applied_L", "los_command_L", "los_nominal_L"):
        panels.append(("acceleration", 1.0))
    if has("los_mpc_status", "los_fallback"):
        panels.append(("status", 0.4))
    if not panels:
        return None

    def draw(kind, ax, edges):
        if kind == "range":
            _panel_range(ax, log, edges)
        elif kind == "faces":
            _panel_faces(ax, log, edges)
        elif kind == "acceleration":
            _panel_acceleration(ax, log)
        else:
            _panel_status(ax, log, edges)

    heading = "Rotating LOS corridor guidance (paper 004, Secs. 5-7)"
    return stacked_time_figure(log, title, heading, panels, draw)


# --------------------------------------------------------------------------------------------
# los_body_frame.png


def figure_los_body_frame(log: RunLog, title: str) -> Figure | None:
    """los_body_frame.png (module docstring), or None without LOS data or a path in T."""
    p = log.p_TC_T()
    if not (_is_los_run(log) and has_finite(p)):
        return None
    R_TK = log.get("los_R_TK")  # a corridor about another axis: drawn in its frame K
    if R_TK is not None:
        R_TK = R_TK[0].reshape(3, 3)
        p = p @ R_TK
    default = LosCorridor()
    alpha_deg = constant_value(log.get("los_half_angle_deg"))
    alpha_label = "α_c = {:.3g}°"
    if alpha_deg is None:
        half_angles = log.get("los_half_angle_deg")
        if has_finite(half_angles):  # changed during the run: the last one
            alpha_deg = float(half_angles[np.isfinite(half_angles)][-1])
            alpha_label += " (last)"
        else:
            alpha_deg = math.degrees(default.half_angle_rad)
            alpha_label += " (assumed: not logged)"
    faces = _face_distances(log)
    floor_y = _floor_y(p, faces)
    floor_label = "floor y_" + ("T" if R_TK is None else "K") + " = {:.3g} m"
    if floor_y is None:
        floor_y, floor_label = default.floor_m, floor_label + " (assumed: not logged)"
    n_f = faces.shape[1] - 1 if faces is not None else default.faces
    slopes = section_slopes(math.radians(alpha_deg), n_f)
    hold = log.get("los_hold_point_T")
    holds = hold_points(hold) if hold is not None else np.empty((0, 3))
    if R_TK is not None:
        holds = holds @ R_TK
    violating = (
        np.fmin.reduce(faces, axis=1) < -VIOLATION_TOLERANCE_M
        if faces is not None
        else np.zeros(len(p), bool)
    )
    ys = np.concatenate([p[:, 1], holds[:, 1], [floor_y]])
    y_top = 1.1 * float(np.nanmax(ys)) if np.isfinite(ys).any() else 1.0
    y_top = max(y_top, 1.5 * floor_y, 1e-3)

    fig = Figure(figsize=(14, 7.0), dpi=DPI)
    fig.suptitle(
        figure_title(
            title,
            (
                "Chaser in the target body frame T with the LOS corridor (axis +y_T): "
                if R_TK is None
                else "Chaser in the corridor frame K (+y_K the docking axis) with the LOS "
                "corridor: "
            )
            + alpha_label.format(alpha_deg)
            + ", "
            + floor_label.format(floor_y)
            + f", {n_f} faces",
        )
    )
    gs = grid(fig, 1, 2, right=0.2, bottom=0.6, top=0.75, wspace=0.22)
    f = "T" if R_TK is None else "K"  # the frame drawn
    for col, (i_h, name) in enumerate(((0, f"x_{f}"), (2, f"z_{f}"))):
        ax = fig.add_subplot(gs[0, col])
        h, v = p[:, i_h], p[:, 1]
        # The corridor's section by this plane: the floor up to y_top, between the two faces.
        s_minus, s_plus = slopes[i_h : i_h + 2]
        y_f = max(floor_y, 0.0)
        ax.fill(
            [-s_minus * y_f, s_plus * y_f, s_plus * y_top, -s_minus * y_top],
            [y_f, y_f, y_top, y_top],
            color="tab:green",
            alpha=0.12,
            lw=0,
            label="corridor section",
        )
        ax.plot(
            [-s_minus * y_top, 0.0, s_plus * y_top], [y_top, 0.0, y_top], color="tab:green", lw=1.0
        )
        ax.plot(
            [-s_minus * y_f, s_plus * y_f],
            [floor_y, floor_y],
            color="tab:brown",
            lw=1.5,
            label="floor",
        )
        ax.plot(h, v, color="tab:blue", lw=0.9, label="chaser")
        if violating.any():
            ax.plot(
                h[violating],
                v[violating],
                ".",
                color="tab:red",
                ms=3,
                label="violating samples",
                zorder=4,
            )
        mark_start_end(ax, h, v)
        ax.plot([0.0], [0.0], "*", color="k", ms=11, label="target (T origin)", zorder=4)
        if len(holds):
            ax.plot(
                holds[:, i_h],
                holds[:, 1],
                "X",
                color="tab:purple",
                ms=9,
                label="hold point",
                zorder=5,
            )
        ax.set_xlabel(f"{name} [m]")
        ax.set_ylabel(f"y_{f} (docking axis) [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
        cut = f"z_{f} = 0" if i_h == 0 else f"x_{f} = 0"
        ax.set_title(f"{name}-y_{f} plane, with the corridor's section by {cut}", fontsize=10)
        if col == 0:
            ax.legend(loc="best", fontsize=8)
    return fig
