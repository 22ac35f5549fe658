"""PNG figures of paper 001's coupled 6-DOF NMPC (Sec. IV, Figs. 6-7), from a run's log.

Owns: the figure functions `figure_coupled_state`, `figure_coupled_thrusters` and
`figure_coupled_nmpc` and their `run_figures()`, which the plug-in hands
rpod.diagrams.plots.write_plots. Does not own: the model (frames, constraints:
rpod.models.coupled_relative, rpod.models.gimbal), the controller, the log and the measures
drawn (metrics.py: `gimbal_face_angles`, `los_counted_outside`, `outside_summary`), nor writing
the files (plots.write_plots: atomic saves through `save_figure`, stale files removed, a figure
that fails only warns, shapes checked by `plots.RunLog` against the generic shapes and the
plug-in's `log_shapes`, plugin.py).

Log keys (N samples, time first; all drawn only when coupled_eigenaxis_error_rad is logged):
  coupled_eigenaxis_error_rad (N)      theta_c/t = acos((tr R_TC - 1) / 2) (eq. 5) [rad].
  coupled_w_TC_T_rad_s (N, 3)          w_TC_T, chaser rate relative to the target, in T [rad/s].
  coupled_p_PtPc_T_m (N, 3)            p_PtPc_T, rock Pt to end effector Pc, in T [m].
  coupled_v_PtPc_T_m_s (N, 3)          its derivative seen in T, in T [m/s].
  coupled_thruster_forces_C_N (N, 3n)  applied force f_k of each thruster on the chaser, in C,
                                       3 per thruster in the order of `gimbaled_cuboid_8` [N].
  coupled_force_C_N (N, 3)             resultant force f_C = sum f_k (eq. 11) [N].
  coupled_torque_C_Nm (N, 3)           resultant torque tau_C = sum p_CK x f_k (eq. 12) [N m].
  coupled_los_margin_m (N)             distance inside the LOS pyramid (eq. 18), positive inside.
  coupled_max_thrust_N (N)             f_max of eq. 17 [N].
  coupled_gimbal_half_angle_rad (N)    the gimbal pyramid's half-angle alpha of eq. 16 [rad].
  nmpc_status (N)                      the last solve's status code, as
                                       rpod.systems.coupled_nmpc_controller.STATUS_CODES maps
                                       NmpcStatus (0 solved, ...; NO_SOLVE_CODE -1 before the
                                       first solve); a code not there is drawn as "code k".
  nmpc_fallback (N)                    what was flown, NmpcFallback of the same module (0 the
                                       new plan's u*(0), 1 the previous plan, 2 zero thrust).
  nmpc_solve_time_s (N)                wall-clock time of the last solve [s].

Figures:
  coupled_state.png      (Fig. 6) (a) eigenaxis error [deg]; (b) w_TC_T components and norm;
                         (c) |p_PtPc_T| (bold) and components; (d) v_PtPc_T components and norm.
  coupled_thrusters.png  (Fig. 7) (a) resultant force and (b) torque in C; (c) |f_k| of each
                         thruster against f_max (eq. 17); (d) each thruster's gimbal face-angle
                         against alpha (eq. 16).
  coupled_nmpc.png       (a) LOS margin (outside shaded red, time outside and the last exit in
                         the title; the samples the outcome line counts); (b) the NMPC's solve time; (c) status and fallback strips.

Decisions:
- Gimbal angle: plotted, the largest face-angle phi_k of metrics.py's `gimbal_face_angles`
  (the angle of f off its nominal direction n in the plane of n and a lateral axis of eq. 16's
  pyramid). For f != 0, phi_k <= alpha exactly when A_k f <= 0 (every row), so the
  curve touches the alpha line when a face is active and crosses it only when eq. 16 is violated;
  the cone angle of f off n would cross it at the corners, where eq. 16 still holds. A force
  below 1e-4 f_max has no meaningful direction: its angle is not drawn (NaN).
- The layout is rebuilt as gimbaled_cuboid_8 over the chaser of Sec. IV
  (rpod.models.coupled_relative.CHASER_SIZE_M); only its directions and lateral axes are used,
  which do not depend on f_max or alpha. f_max and alpha come from the log, else Sec. IV's
  values, marked "assumed". The resultant force and torque are computed from the thruster forces
  (eqs. 11-12) when they are not logged, and said so.
- Log scale where it shows convergence: a positive series (eigenaxis error, norms, solve time)
  on a log axis when it spans >= 2 decades; signed components on a symlog axis, linear within
  1e-3 of the largest magnitude, when they span >= 2 decades beyond that.
- Codes (status, fallback) are drawn with the kit's `code_bands`: one rectangle per run of equal
  consecutive values over its time edges, a marker at the start of every failure or fallback.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from rpod.diagrams.controllers.coupled_nmpc.metrics import (
    DISTANCE_TOLERANCE_M,
    LOS_TOLERANCE_M,
    gimbal_face_angles,
    los_counted_outside,
    outside_summary,
)
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
    stacked_time_figure,
    time_edges,
)
from rpod.models import coupled_relative as cr
from rpod.models.thrusters import ThrusterLayout, gimbaled_cuboid_8

_logger = logging.getLogger(__name__)


FIGURE_NAMES = ("coupled_state.png", "coupled_thrusters.png", "coupled_nmpc.png")


def run_figures() -> dict:
    """The coupled NMPC's run figures: {file name: draw(log, title)} (read when called, so a patched figure is drawn)."""
    return dict(
        zip(
            FIGURE_NAMES,
            (
                figure_coupled_state,
                figure_coupled_thrusters,
                figure_coupled_nmpc,
            ),
        )
    )


_MIN_FORCE_FRACTION = 1e-4  # of f_max: a smaller force's direction is not drawn
_DECADES = 100.0  # a series spanning this ratio gets a log (or symlog) axis
_SYMLOG_FRACTION = 1e-3  # symlog's linear band, as a fraction of the largest magnitude
_STATUS_COLOURS = {
    "solved": "tab:green",
    "max_iterations": "tab:orange",
    "infeasible": "tab:red",
    "solver_unavailable": "tab:purple",
    "failed": "darkred",
}
_FALLBACK_COLOURS = {"NONE": "#cfe8cf", "PREVIOUS_PLAN": "tab:orange", "ZERO_THRUST": "tab:red"}


# --------------------------------------------------------------------------------------------
# Computations


def _rebuilt_layout() -> ThrusterLayout:
    """Sec. IV's eight gimbaled thrusters (directions and lateral axes; limits unused)."""
    return gimbaled_cuboid_8(size=cr.CHASER_SIZE_M)


def _thruster_forces(log: RunLog, count: int, warn: bool = False) -> np.ndarray | None:
    """coupled_thruster_forces_C_N as (N, n, 3), when it has 3 columns per thruster."""
    F = log.get("coupled_thruster_forces_C_N")
    if F is None:
        return None
    if F.shape[1] % 3 or (count and F.shape[1] != 3 * count):
        if warn:
            _logger.warning(
                "plots: log['coupled_thruster_forces_C_N'] has %d columns, expected %s; skipped",
                F.shape[1],
                3 * count if count else "a multiple of 3",
            )
        return None
    return F.reshape(len(F), -1, 3)


def _logged_level(log: RunLog, key: str, default: float) -> tuple[float, bool]:
    """(value, assumed): a constant logged level, its last finite value, or the default."""
    values = log.get(key)
    if (c := constant_value(values)) is not None:
        return c, False
    if has_finite(values):
        return float(values[np.isfinite(values)][-1]), False
    return default, True


# --------------------------------------------------------------------------------------------
# Drawing helpers


def _positive_scale(ax, values: np.ndarray) -> None:
    """Log axis when the finite values are all positive and span >= 2 decades."""
    finite = values[np.isfinite(values)]
    if len(finite) and finite.min() > 0.0 and finite.max() / finite.min() >= _DECADES:
        ax.set_yscale("log")


def _signed_scale(ax, values: np.ndarray) -> None:
    """Symlog axis when the largest magnitude exceeds the smallest nonzero one by 2 decades:
    linear within _SYMLOG_FRACTION of the largest magnitude."""
    magnitude = np.abs(values[np.isfinite(values)])
    nonzero = magnitude[magnitude > 0.0]
    if not len(nonzero) or nonzero.max() / nonzero.min() < _DECADES:
        return
    ax.set_yscale("symlog", linthresh=_SYMLOG_FRACTION * float(nonzero.max()))
    ax.axhline(0.0, color="k", lw=0.6, ls=":")


def _components(ax, t, values, symbol: str, frame: str, norm: bool) -> None:
    """Three components (x red, y green, z blue) and, optionally, the norm in black."""
    t_env, v_env = envelope(t, values)
    for j, name in enumerate("xyz"):
        ax.plot(
            t_env[:, j],
            v_env[:, j],
            color=COMPONENT_COLOURS[j],
            lw=0.9,
            label=f"{symbol}_{name} ({frame})",
        )
    if norm:
        ax.plot(*envelope(t, np.linalg.norm(values, axis=1)), color="k", lw=1.4, label="norm")


def _finish_time_axes(axes, log: RunLog, edges) -> None:
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel(log.t_label)
    axes[-1].set_xlim(edges[0], edges[-1])


def _final(values: np.ndarray) -> float | None:
    finite = values[np.isfinite(values)]
    return float(finite[-1]) if len(finite) else None


def _is_coupled_run(log: RunLog) -> bool:
    return has_finite(log.get("coupled_eigenaxis_error_rad"))


# --------------------------------------------------------------------------------------------
# coupled_state.png (paper 001 Fig. 6)


def figure_coupled_state(log: RunLog, title: str) -> Figure | None:
    """coupled_state.png (module docstring), or None without coupled_eigenaxis_error_rad."""
    if not _is_coupled_run(log):
        return None
    t = log.t
    panels = [("attitude", log.get("coupled_eigenaxis_error_rad"))]
    for key in ("coupled_w_TC_T_rad_s", "coupled_p_PtPc_T_m", "coupled_v_PtPc_T_m_s"):
        if has_finite(log.get(key)):
            panels.append((key, log.get(key)))
    edges = time_edges(t)
    fig = Figure(figsize=(13, 2.6 * len(panels) + 1.3), dpi=DPI)
    fig.suptitle(
        figure_title(
            title, "Coupled 6-DOF NMPC: relative attitude and feature points (paper 001 Fig. 6)"
        )
    )
    gs = grid(fig, len(panels), 1, left=1.1, right=2.3, hspace=0.45)
    axes = []
    for i, (kind, values) in enumerate(panels):
        ax = fig.add_subplot(gs[i, 0], sharex=axes[0] if axes else None)
        axes.append(ax)
        if kind == "attitude":
            theta_deg = np.degrees(values)
            ax.plot(*envelope(t, theta_deg), color="k", lw=1.2, label="θ_c/t")
            _positive_scale(ax, theta_deg)
            ax.set_ylabel("eigenaxis error [deg]")
            end = _final(theta_deg)
            ax.set_title(
                "eigenaxis attitude error θ = acos((tr R_TC - 1) / 2) (eq. 5)"
                + (f", final {end:.3g} deg" if end is not None else ""),
                fontsize=10,
            )
        elif kind == "coupled_w_TC_T_rad_s":
            _components(ax, t, values, "ω", "T", norm=True)
            _signed_scale(ax, values)
            ax.set_ylabel("ω_TC_T [rad/s]")
            ax.set_title("angular velocity of C relative to T, in T", fontsize=10)
        elif kind == "coupled_p_PtPc_T_m":
            distance = np.linalg.norm(values, axis=1)
            _components(ax, t, values, "p", "T", norm=False)
            ax.plot(*envelope(t, distance), color="k", lw=1.8, label="|p_PtPc| distance")
            _signed_scale(ax, values)
            ax.set_ylabel("p_PtPc_T [m]")
            end = _final(distance)
            ax.set_title(
                "feature points: rock Pt to end effector Pc, in T"
                + (f", final distance {end:.3g} m" if end is not None else ""),
                fontsize=10,
            )
        else:
            _components(ax, t, values, "v", "T", norm=True)
            _signed_scale(ax, values)
            ax.set_ylabel("v_PtPc_T [m/s]")
            ax.set_title("feature points' relative velocity (seen in T), in T", fontsize=10)
        ax.legend(**LEGEND_OUTSIDE)
        ax.grid(True, which="both", alpha=0.3)
    _finish_time_axes(axes, log, edges)
    return fig


# --------------------------------------------------------------------------------------------
# coupled_thrusters.png (paper 001 Fig. 7)


def _per_thruster(ax, t, values: np.ndarray, colours) -> None:
    t_env, v_env = envelope(t, values)
    for k in range(values.shape[1]):
        ax.plot(t_env[:, k], v_env[:, k], color=colours[k], lw=0.9, label=f"k = {k + 1}")


def figure_coupled_thrusters(log: RunLog, title: str) -> Figure | None:
    """coupled_thrusters.png (module docstring), or None without coupled data or forces."""
    if not _is_coupled_run(log):
        return None
    t = log.t
    layout = _rebuilt_layout()
    F = _thruster_forces(log, layout.count, warn=True)
    force, torque = log.get("coupled_force_C_N"), log.get("coupled_torque_C_Nm")
    derived = ""
    if F is not None and not (has_finite(force) or has_finite(torque)):
        force = F.sum(axis=1)  # f_C = sum_k f_k (eq. 11)
        torque = np.cross(layout.p_CK_C[None], F).sum(axis=1)  # tau_C = sum p_CK x f_k (eq. 12)
        derived = " (from the thruster forces)"
    f_max, f_max_assumed = _logged_level(log, "coupled_max_thrust_N", cr.MAX_THRUST_N)
    alpha, alpha_assumed = _logged_level(
        log, "coupled_gimbal_half_angle_rad", cr.GIMBAL_HALF_ANGLE_RAD
    )
    panels = []
    if has_finite(force):
        panels.append("force")
    if has_finite(torque):
        panels.append("torque")
    if F is not None and has_finite(F):
        panels += ["magnitude", "gimbal"]
    if not panels:
        return None
    edges = time_edges(t)
    colours = [colormaps["tab10"](k % 10) for k in range(layout.count)]
    fig = Figure(figsize=(13, 2.6 * len(panels) + 1.3), dpi=DPI)
    fig.suptitle(
        figure_title(title, "Coupled 6-DOF NMPC: chaser wrench and thrusters (paper 001 Fig. 7)")
    )
    gs = grid(fig, len(panels), 1, left=1.1, right=2.3, hspace=0.45)
    axes = []
    for i, kind in enumerate(panels):
        ax = fig.add_subplot(gs[i, 0], sharex=axes[0] if axes else None)
        axes.append(ax)
        if kind == "force":
            _components(ax, t, force, "f", "C", norm=False)
            ax.set_ylabel("f_C [N]")
            ax.set_title(f"resultant force on the chaser, in C (eq. 11){derived}", fontsize=10)
        elif kind == "torque":
            _components(ax, t, torque, "τ", "C", norm=False)
            ax.set_ylabel("τ_C [N m]")
            ax.set_title(
                f"resultant torque about the chaser CoM, in C (eq. 12){derived}", fontsize=10
            )
        elif kind == "magnitude":
            magnitude = np.linalg.norm(F, axis=2)
            _per_thruster(ax, t, magnitude, colours)
            limit = log.get("coupled_max_thrust_N")
            if has_finite(limit):
                draw_level(ax, t, limit, color="k", ls="--", lw=1.0)
            else:
                ax.axhline(f_max, color="k", ls="--", lw=1.0)
            largest = float(np.nanmax(magnitude)) if has_finite(magnitude) else float("nan")
            ax.set_ylim(-0.03 * f_max, 1.1 * max(f_max, largest))
            ax.set_ylabel("|f_k| [N]")
            ax.set_title(
                f"thrust magnitude per thruster; dashed: f_max = {f_max:.3g} N (eq. 17)"
                + (" (assumed: not logged)" if f_max_assumed else "")
                + f"; largest {largest:.3g} N",
                fontsize=10,
            )
        else:
            phi = gimbal_face_angles(layout, F, min_force_N=_MIN_FORCE_FRACTION * f_max)
            phi_deg = np.degrees(phi)
            _per_thruster(ax, t, phi_deg, colours)
            limit = log.get("coupled_gimbal_half_angle_rad")
            if has_finite(limit):
                draw_level(ax, t, np.degrees(limit), color="k", ls="--", lw=1.0)
            else:
                ax.axhline(math.degrees(alpha), color="k", ls="--", lw=1.0)
            largest = float(np.nanmax(phi_deg)) if has_finite(phi_deg) else float("nan")
            top = max(math.degrees(alpha), largest if math.isfinite(largest) else 0.0)
            ax.set_ylim(0.0, 1.15 * top)
            ax.set_ylabel("face-angle φ_k [deg]")
            corner = math.degrees(math.atan(math.sqrt(2.0) * math.tan(alpha)))
            ax.set_title(
                "gimbal: largest angle of f_k off its nominal direction in a face plane of the "
                f"pyramid; dashed: α = {math.degrees(alpha):.3g} deg (eq. 16)"
                + (" (assumed: not logged)" if alpha_assumed else "")
                + f"\n(φ ≤ α ⇔ A_k f_k ≤ 0; a corner is φ = α at a cone angle of {corner:.3g} deg;"
                + f" largest φ {largest:.3g} deg; not drawn below {_MIN_FORCE_FRACTION:g} f_max)",
                fontsize=10,
            )
        if kind in ("magnitude", "gimbal"):
            handles, labels = ax.get_legend_handles_labels()
            handles.append(Line2D([], [], color="k", ls="--", lw=1.0))
            labels.append("limit")
            ax.legend(handles, labels, ncol=2, **LEGEND_OUTSIDE)
        else:
            ax.legend(**LEGEND_OUTSIDE)
        ax.grid(True, which="both", alpha=0.3)
    _finish_time_axes(axes, log, edges)
    return fig


# --------------------------------------------------------------------------------------------
# coupled_nmpc.png


def _present(styles: dict, codes: np.ndarray) -> dict[int, tuple[str, str]]:
    """The styles of the codes present, a grey "code k" for a code without one."""
    present = np.unique(np.round(codes[np.isfinite(codes)])).astype(int)
    for code in present:
        styles.setdefault(int(code), (f"code {code}", "0.4"))
    return {code: style for code, style in styles.items() if code in present}


def _status_styles(codes: np.ndarray) -> dict[int, tuple[str, str]]:
    """(label, colour) of each status code present, from the controller's STATUS_CODES."""
    from rpod.systems.coupled_nmpc_controller import NO_SOLVE_CODE, STATUS_CODES  # when drawing

    styles = {NO_SOLVE_CODE: ("not solved yet", "0.8")}
    for status, code in STATUS_CODES.items():
        styles[code] = (status.replace("_", " "), _STATUS_COLOURS.get(status, "0.5"))
    return _present(styles, codes)


def _fallback_styles(codes: np.ndarray) -> dict[int, tuple[str, str]]:
    """(label, colour) of each fallback code present, from the controller's NmpcFallback."""
    from rpod.systems.coupled_nmpc_controller import NmpcFallback  # only when drawing

    styles = {
        int(f): (
            "new plan's u*(0)" if f == 0 else f.name.lower().replace("_", " "),
            _FALLBACK_COLOURS.get(f.name, "0.5"),
        )
        for f in NmpcFallback
    }
    return _present(styles, codes)


def _panel_los(ax, log: RunLog, edges) -> None:
    # The samples the run's outcome line counts (metrics.py's rule), so the two agree.
    t, margin = log.t, log.get("coupled_los_margin_m")
    p = log.get("coupled_p_PtPc_T_m")
    distance = np.linalg.norm(p, axis=1) if p is not None else np.full(len(t), np.inf)
    outside = los_counted_outside(margin, distance)
    code_bands(
        ax, edges, outside.astype(float), {1: ("outside the LOS pyramid", "tab:red")}, alpha=0.15
    )
    ax.plot(*envelope(t, margin), color="k", lw=1.2, label="margin (positive inside)")
    ax.axhline(0.0, color="tab:red", lw=0.9, ls="--")
    _signed_scale(ax, margin)
    counted = np.where(outside, margin, 0.0)
    duration, depth, exit_s = outside_summary(t, counted)
    if depth == 0.0:
        text = "inside throughout"
    else:
        text = f"outside for {duration:.4g} s, deepest {depth:.3g} m; " + (
            f"inside from t = {exit_s:.4g} s on" if exit_s is not None else "outside at the end"
        )
    ax.set_ylabel("LOS margin [m]")
    ax.set_title(
        f"distance inside the LOS pyramid at the rock (eq. 18): {text}\n(counted: more than "
        f"{1e3 * LOS_TOLERANCE_M:g} mm outside, beyond {DISTANCE_TOLERANCE_M:g} m of the rock, "
        "as in the run's line)",
        fontsize=10,
    )
    ax.legend(**LEGEND_OUTSIDE)


def _panel_solve_time(ax, log: RunLog) -> None:
    t, solve = log.t, log.get("nmpc_solve_time_s")
    ax.plot(*envelope(t, solve), color="tab:blue", lw=1.0, drawstyle="steps-post")
    _positive_scale(ax, solve)
    finite = solve[np.isfinite(solve)]
    ax.set_ylabel("solve time [s]")
    ax.set_title(
        f"NMPC solve time (wall clock): median {np.median(finite):.3g} s, max {finite.max():.3g} s",
        fontsize=10,
    )


def _panel_status(ax, log: RunLog, edges) -> None:
    t = log.t
    rows = []
    status = log.get("nmpc_status")
    if has_finite(status):
        rows.append(("NMPC status", status, _status_styles(status), 1))
    fallback = log.get("nmpc_fallback")
    if has_finite(fallback):
        rows.append(("fallback", fallback, _fallback_styles(fallback), 1))
    for k, (_, codes, styles, failure) in enumerate(rows):  # the first row on top
        row = len(rows) - 1 - k
        code_bands(ax, edges, codes, styles, y=(row - 0.35, row + 0.35), axes_y=False, percent=True)
        values, starts, _ = code_runs(codes)
        events = starts[values >= failure]
        ax.plot(t[events], np.full(len(events), row + 0.42), "v", color="k", ms=4, zorder=5)
    ax.set_yticks(np.arange(len(rows)))
    ax.set_yticklabels([name for name, *_ in reversed(rows)])
    ax.set_ylim(-0.6, len(rows) - 0.35)
    ax.legend(**LEGEND_OUTSIDE)
    ax.set_title("NMPC status and fallback (▼: a failure or fallback starts)", fontsize=10)


def figure_coupled_nmpc(log: RunLog, title: str) -> Figure | None:
    """coupled_nmpc.png (module docstring), or None without coupled data or any of its keys."""
    if not _is_coupled_run(log):
        return None
    panels = []
    if has_finite(log.get("coupled_los_margin_m")):
        panels.append(("los", 1.0))
    if has_finite(log.get("nmpc_solve_time_s")):
        panels.append(("solve", 0.8))
    if has_finite(log.get("nmpc_status"), log.get("nmpc_fallback")):
        panels.append(("status", 0.4))
    if not panels:
        return None

    def draw(kind, ax, edges):
        if kind == "los":
            _panel_los(ax, log, edges)
        elif kind == "solve":
            _panel_solve_time(ax, log)
        else:
            _panel_status(ax, log, edges)

    heading = "Coupled 6-DOF NMPC: line of sight and solver (paper 001)"
    return stacked_time_figure(log, title, heading, panels, draw)
