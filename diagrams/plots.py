"""PNG plots of a run's log: the generic figures of every run, and the kit the methods draw with.

Owns: `write_plots` (the `plots/*.png` of `rpod run`, DESIGN.md "Command line and outputs"), the
generic figures below, and the public plotting kit (next section) with which a controller
package draws its own figures. Does not own: any method's figures or log keys (each controller
package's `figures.py`, reached through `ControllerPlugin.run_figures()` and `log_shapes`,
rpod.diagrams.controller_seam), the simulation or the log itself, nor Meshcat recordings
(rpod.diagrams.recording).

Generic figures, one file each (`FIGURE_NAMES`):
  trajectory_lvlh.png          chaser in LVLH (L): y-x (V-bar horizontal, R-bar vertical), y-z, 3-D;
                               start/end marked; the commanded hold point when logged.
  trajectory_target_body.png   chaser in the target body frame T: components vs time and a 3-D path.
  thrust.png                   body torque and force (chaser frame C) and propellant used vs time.
  duty.png                     thruster duty cycles and the on/off pattern vs time.
  separation.png               separation distance and range |p_LC_L| vs time.
Then each plug-in's `run_figures()` (`write_plots(..., plugins=...)`; by default every registered
plug-in), in the plug-ins' order: a figure whose log has no data for it is not written.

The kit (public; a controller package imports these, never the private names):
  RunLog(log, extra_shapes)    the usable arrays of a log: `GENERIC_SHAPES` plus a plug-in's
                               `log_shapes` checked, `.get(key)`, `.t`, `.t_label`, `.when(i)`,
                               `.p_TC_T()`.
  figure_title, has_finite, equal_aspect_3d, mark_start_end, hold_points, envelope,
  time_edges, grid, stacked_time_figure, heatmap, save_figure, DPI, COMPONENT_COLOURS
                               titles, data checks, layout (margins in inches), dense series at
                               screen resolution, the atomic PNG writer.
  code_runs, code_bands, constant_value, draw_level, LEGEND_OUTSIDE
                               status codes drawn as coloured strips (one rectangle per run of
                               equal codes), reference levels, a legend right of its panel.
  chaser_in_target_frame       p_TC_T from the logged attitudes (rpod.diagrams.target_frame).

Decisions, written down as DESIGN.md asks:
- A method's figures come through the seam: plots.py names no controller and imports none;
  `run_figures()` imports its plotting module when called, so loading a scenario never imports
  matplotlib. The log is checked once against the generic shapes and every given plug-in's
  `log_shapes` (a key already declared keeps its first shape: the generic one, then the
  plug-ins' in order); a figure name already taken is skipped with a warning.
- matplotlib through `matplotlib.figure.Figure` + the Agg canvas, never pyplot: no global figure
  registry, no backend switching, safe to call from worker threads (sweeps).
- Missing data is not an error: a key that is absent, has the wrong shape, has zero columns or a
  first axis that disagrees with the log's N is ignored; a panel without data is omitted, a figure
  without any is not written (and a stale file of that name from an earlier run in the same folder
  is removed, so the folder never mixes runs). If drawing a figure still fails, the error is logged
  as a warning with its traceback and the other figures are written: plots are a side output and
  must never cost the run's other results. A missing `t` falls back to the sample index.
- Each PNG is written to a hidden temporary name in the same folder, then `os.replace`d, so an
  interrupted run never leaves a truncated file under the final name (no fsync: this guards
  against a killed process, not against a power cut).
- Heatmaps (duty and on/off with more than `MAX_DUTY_LINES` thrusters) are averaged over blocks
  of consecutive samples down to at most `MAX_HEATMAP_COLUMNS` columns; sample i is drawn over
  [t_i, t_{i+1}) (zero-order hold, as the duty is commanded), with pcolormesh so non-uniform
  sampling is drawn at its true times. Averaged on/off cells read as the fraction of time on.
- p_TC_T = R_IT^T R_IL p_LC_L: rpod.diagrams.target_frame (vectorised numpy quaternion rotation).
- Log scale for separation/range when every value is positive and they span >= 2 decades. A
  separation <= 0 (contact or penetration) gets a zero line and, if the run still spans decades,
  a symlog scale, linear within max(penetration depth, 1e-4 x largest distance) of zero.
"""

from __future__ import annotations

import logging
import os
import uuid
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d import Axes3D  # noqa: F401  (registers the "3d" projection)

from rpod.diagrams import controller_seam
from rpod.diagrams.target_frame import chaser_in_target_frame  # in the kit too

_logger = logging.getLogger(__name__)

FIGURE_NAMES = (
    "trajectory_lvlh.png",
    "trajectory_target_body.png",
    "thrust.png",
    "duty.png",
    "separation.png",
)
MAX_DUTY_LINES = 6  # more thrusters than this: duty drawn as a heatmap
MAX_HEATMAP_COLUMNS = 800  # time columns of a heatmap after block averaging
MAX_LINE_BUCKETS = 1000  # dense time series drawn as the min/max envelope of this many runs
DPI = 100
COMPONENT_COLOURS = ("tab:red", "tab:green", "tab:blue")
LEGEND_OUTSIDE = {  # right of the panel: the time axis stays clear
    "loc": "upper left",
    "bbox_to_anchor": (1.005, 1.0),
    "fontsize": 8,
    "frameon": False,
}

# Expected trailing shape of each generic key (None: one value per sample; -1: any column count).
# A plug-in declares its own keys in `ControllerPlugin.log_shapes`, in the same form.
GENERIC_SHAPES = {
    "t": None,
    "p_LC_L": 3,
    "v_LC_L": 3,
    "q_IT": 4,
    "w_IT_T": 3,
    "q_IC": 4,
    "w_IC_C": 3,
    "q_IL": 4,
    "thruster_duty": -1,
    "thruster_on": -1,
    "thruster_delivered_duty": -1,
    "thruster_force_C": -1,  # a gimbaled bank's force vectors (3 per thruster, in C)
    "body_wrench": 6,
    "propellant_kg": None,
    "separation_m": None,
    "hold_point_L": 3,  # a commanded hold point, drawn in trajectory_lvlh.png
    "p_TC_T": 3,
}


# --------------------------------------------------------------------------------------------
# Log access


class RunLog:
    """The usable arrays of a log, as float arrays with a common first axis N.

    Args:
        log: Time series keyed by name, time as the first axis.
        extra_shapes: Shapes of further keys (a plug-in's `log_shapes`), in the form of
            `GENERIC_SHAPES`; a key that is there too keeps its generic shape.
    """

    def __init__(self, log: Mapping[str, np.ndarray], extra_shapes: Mapping | None = None):
        self.arrays: dict[str, np.ndarray] = {}
        raw = {}
        shapes = dict(GENERIC_SHAPES)
        for key, width in (extra_shapes or {}).items():
            shapes.setdefault(key, width)
        for key, width in shapes.items():
            if key not in log:
                continue
            try:
                a = np.asarray(log[key], dtype=float)
            except (TypeError, ValueError):
                _logger.warning("plots: log[%r] is not numeric; skipped", key)
                continue
            if width is None:
                a = a.reshape(-1) if a.ndim == 2 and a.shape[1] == 1 else a
                ok = a.ndim == 1
            elif width == -1:
                ok = a.ndim == 2 and a.shape[1] > 0
            else:
                ok = a.ndim == 2 and a.shape[1] == width
            if not ok:
                if a.size:  # an empty (N, 0) block is the normal "no thrusters", not worth a word
                    _logger.warning("plots: log[%r] has shape %s; skipped", key, a.shape)
                continue
            raw[key] = a
        t = raw.get("t")
        self.n = len(t) if t is not None else (len(next(iter(raw.values()))) if raw else 0)
        for key, a in raw.items():
            if len(a) != self.n:
                _logger.warning(
                    "plots: log[%r] has %d samples, t has %d; skipped", key, len(a), self.n
                )
                continue
            self.arrays[key] = a
        if "t" in self.arrays:
            self.t, self.t_label = self.arrays["t"], "t [s]"
        else:
            self.t, self.t_label = np.arange(self.n, dtype=float), "sample [-]"

    def when(self, i: int) -> str:
        """Sample i's time, for a label."""
        return f"t = {self.t[i]:.6g} s" if "t" in self.arrays else f"sample {i}"

    def get(self, key: str) -> np.ndarray | None:
        return self.arrays.get(key)

    def p_TC_T(self) -> np.ndarray | None:
        if (p := self.get("p_TC_T")) is not None:
            return p
        q_IT, q_IL, p_LC_L = self.get("q_IT"), self.get("q_IL"), self.get("p_LC_L")
        if q_IT is None or q_IL is None or p_LC_L is None:
            return None
        return chaser_in_target_frame(q_IT, q_IL, p_LC_L)


# --------------------------------------------------------------------------------------------
# Helpers


def figure_title(title: str, what: str) -> str:
    """A figure's title: the run's title (e.g. the scenario name), a dash, what it shows."""
    return f"{title} — {what}" if title else what


def has_finite(*arrays: np.ndarray | None) -> bool:
    """True when any of the arrays (None: absent) holds a finite value."""
    return any(a is not None and np.isfinite(a).any() for a in arrays)


def equal_aspect_3d(ax, points: np.ndarray) -> None:
    """Equal scale on the three axes, centred on the finite points' bounding box."""
    finite = points[np.isfinite(points).all(axis=1)]
    if not len(finite):
        return
    lo, hi = finite.min(axis=0), finite.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * max(float((hi - lo).max()), 1e-9) * 1.05
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))


def mark_start_end(ax, a, b, c=None) -> None:
    """Marks the first and last finite samples of a path (2-D or 3-D)."""
    cols = (a, b) if c is None else (a, b, c)
    finite = np.flatnonzero(np.all([np.isfinite(x) for x in cols], axis=0))
    if not len(finite):
        return
    i0, i1 = finite[0], finite[-1]
    ax.plot(*(x[i0 : i0 + 1] for x in cols), "o", color="tab:green", ms=7, label="start", zorder=5)
    ax.plot(*(x[i1 : i1 + 1] for x in cols), "s", color="tab:red", ms=7, label="end", zorder=5)


def hold_points(hold: np.ndarray) -> np.ndarray:
    """The distinct commanded hold points, in order (at most 20; else just the last)."""
    finite = hold[np.isfinite(hold).all(axis=1)]
    if not len(finite):
        return finite
    change = np.r_[True, np.any(np.diff(finite, axis=0) != 0.0, axis=1)]
    distinct = finite[change]
    return distinct if len(distinct) <= 20 else finite[-1:]


def envelope(t: np.ndarray, y: np.ndarray, buckets: int = MAX_LINE_BUCKETS):
    """(t, y) of a dense series reduced to the min and max of each of `buckets` runs of samples,
    in time order: the same picture at screen resolution, a fraction of the drawing time.

    Args:
        t: Times (N,).
        y: Values (N,) or (N, m).

    Returns:
        (t_out, y_out), both shaped like y with at most 2 * buckets rows; per column times for a
        2-D y. Series of at most 2 * buckets samples are returned as they are.
    """
    y2 = y.reshape(len(y), -1)
    n = len(t)
    if n <= 2 * buckets:
        return np.broadcast_to(t[:, None], y2.shape).reshape(y.shape), y
    k = -(-n // buckets)
    pad = (-n) % k
    yp = np.concatenate([y2, np.full((pad, y2.shape[1]), np.nan)]).reshape(-1, k, y2.shape[1])
    tp = np.concatenate([t, np.full(pad, np.nan)]).reshape(-1, k)
    nan = np.isnan(yp)
    i_min = np.where(nan, np.inf, yp).argmin(axis=1)  # (B, m); an all-NaN bucket gives NaN below
    i_max = np.where(nan, -np.inf, yp).argmax(axis=1)
    i_first, i_last = np.minimum(i_min, i_max), np.maximum(i_min, i_max)
    rows = np.arange(yp.shape[0])[:, None]
    cols = np.arange(y2.shape[1])[None, :]
    y_out = np.stack([yp[rows, i_first, cols], yp[rows, i_last, cols]], axis=1)
    t_out = np.stack([tp[rows, i_first], tp[rows, i_last]], axis=1)
    shape = (-1,) + y.shape[1:]
    return t_out.reshape(shape), y_out.reshape(shape)


def time_edges(t: np.ndarray) -> np.ndarray:
    """Edges of the hold intervals [t_i, t_{i+1}); the last one lasts as long as the one before."""
    if len(t) == 1:
        return np.array([t[0], t[0] + 1.0])
    return np.r_[t, t[-1] + (t[-1] - t[-2])]


def _block_mean(t: np.ndarray, a: np.ndarray, max_columns: int) -> tuple[np.ndarray, np.ndarray]:
    """(time edges, values) of (N, n) samples averaged over blocks of k consecutive samples."""
    edges = time_edges(t)
    k = max(1, -(-len(t) // max_columns))
    if k == 1:
        return edges, a
    starts = np.arange(0, len(t), k)
    with np.errstate(invalid="ignore"):
        sums = np.add.reduceat(np.nan_to_num(a), starts, axis=0)
        counts = np.add.reduceat(np.isfinite(a).astype(float), starts, axis=0)
        means = np.where(counts > 0, sums / np.maximum(counts, 1.0), np.nan)
    return np.r_[edges[starts], edges[-1]], means


def grid(fig, nrows, ncols, left=0.85, right=0.25, bottom=0.6, top=0.75, **kwargs):
    """A GridSpec with margins given in inches (a fixed layout: constrained layout costs ~40 %
    of the rendering time, and handles 3-D axes poorly)."""
    width, height = fig.get_size_inches()
    return fig.add_gridspec(
        nrows,
        ncols,
        left=left / width,
        right=1.0 - right / width,
        bottom=bottom / height,
        top=1.0 - top / height,
        **kwargs,
    )


def stacked_time_figure(log: RunLog, title: str, heading: str, panels, draw) -> Figure:
    """A column of time panels sharing their time axis (the paper figures' layout).

    Args:
        panels: [(kind, relative height)], top to bottom.
        draw: draw(kind, ax, edges) fills one panel; a 'status' panel gets a time-only grid.
    """
    edges = time_edges(log.t)
    heights = [h for _, h in panels]
    fig = Figure(figsize=(13, 2.8 * sum(heights) + 1.3), dpi=DPI)
    fig.suptitle(figure_title(title, heading))
    gs = grid(fig, len(panels), 1, left=1.1, right=2.8, hspace=0.45, height_ratios=heights)
    axes = []
    for i, (kind, _) in enumerate(panels):
        ax = fig.add_subplot(gs[i, 0], sharex=axes[0] if axes else None)
        axes.append(ax)
        draw(kind, ax, edges)
        ax.grid(True, which="both", axis="x" if kind == "status" else "both", alpha=0.3)
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel(log.t_label)
    axes[-1].set_xlim(edges[0], edges[-1])
    return fig


def heatmap(fig, ax, cax, t_edges: np.ndarray, values: np.ndarray, label: str, cmap: str) -> None:
    """(N, n) values in [0, 1] as n rows over the time edges, with a colour bar in cax."""
    n = values.shape[1]
    mesh = ax.pcolormesh(
        t_edges,
        np.arange(n + 1) - 0.5,
        values.T,
        cmap=cmap,
        vmin=0.0,
        vmax=1.0,
        shading="flat",
        rasterized=True,
    )
    ax.set_ylim(n - 0.5, -0.5)
    ax.set_yticks(np.arange(n) if n <= 16 else np.linspace(0, n - 1, 9).round().astype(int))
    ax.set_ylabel("thruster k")
    fig.colorbar(mesh, cax=cax, label=label)


def code_runs(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(values, starts, stops) of the runs of equal consecutive codes: samples starts[k] up to
    stops[k] - 1 hold values[k]. Codes are rounded to integers first; NaN samples are left out."""
    c = np.round(np.asarray(codes, dtype=float))
    change = np.flatnonzero((c[1:] != c[:-1]) | np.isnan(c[1:])) + 1
    starts = np.r_[0, change]
    stops = np.r_[change, len(c)]
    keep = np.isfinite(c[starts])
    return c[starts[keep]].astype(int), starts[keep], stops[keep]


def constant_value(values: np.ndarray | None) -> float | None:
    """The value of a series that holds one finite value throughout (up to round-off)."""
    if values is None:
        return None
    finite = values[np.isfinite(values)]
    if not len(finite):
        return None
    lo, hi = finite.min(), finite.max()
    return float(np.median(finite)) if hi - lo <= 1e-9 * max(abs(hi), 1.0) else None


def code_bands(
    ax, edges, codes, styles, y=(0.0, 1.0), axes_y=True, alpha=1.0, percent=False
) -> None:
    """One rectangle per run of equal codes, coloured and labelled by `styles` (code: (label,
    colour)); codes not in `styles` are not drawn. y in axes coordinates unless axes_y is False.
    percent: each label gets the share of the samples holding the code.

    Drawn with `broken_barh` over the time edges, so a switch lasting one sample still shows."""
    values, starts, stops = code_runs(codes)
    n = max(len(codes), 1)
    for code, (label, colour) in styles.items():
        mine = values == code
        if not mine.any():
            continue
        x0, x1 = edges[starts[mine]], edges[stops[mine]]
        if percent:
            label = f"{label} ({100.0 * np.sum(stops[mine] - starts[mine]) / n:.3g} %)"
        kwargs = {"transform": ax.get_xaxis_transform()} if axes_y else {}
        ax.broken_barh(
            np.column_stack([x0, x1 - x0]),
            (y[0], y[1] - y[0]),
            facecolors=colour,
            edgecolors="none",
            alpha=alpha,
            label=label,
            **kwargs,
        )


def draw_level(ax, t, values, **kwargs) -> None:
    """A reference level: a horizontal line when constant, else its (enveloped) time series."""
    if (c := constant_value(values)) is not None:
        ax.axhline(c, **kwargs)
    elif has_finite(values):
        ax.plot(*envelope(t, values), **kwargs)


# --------------------------------------------------------------------------------------------
# Figures. Each returns a Figure, or None when there is nothing to draw.


def _figure_trajectory_lvlh(log: RunLog, title: str) -> Figure | None:
    p = log.get("p_LC_L")
    if not has_finite(p):
        return None
    hold = log.get("hold_point_L")
    holds = hold_points(hold) if hold is not None else np.empty((0, 3))
    x, y, z = p.T
    fig = Figure(figsize=(16, 5.4), dpi=DPI)
    fig.suptitle(
        figure_title(
            title, "Chaser in LVLH (L): x radial (R-bar), y along-track (V-bar), z orbit normal"
        )
    )
    gs = grid(
        fig, 1, 3, right=0.1, bottom=0.55, top=0.65, wspace=0.25, width_ratios=(1.0, 1.0, 1.15)
    )
    ax_yx = fig.add_subplot(gs[0, 0])
    ax_yz = fig.add_subplot(gs[0, 1])
    ax_3d = fig.add_subplot(gs[0, 2], projection="3d")
    for ax, (h, v), (hl, vl) in (
        (ax_yx, (y, x), ("y along-track (V-bar) [m]", "x radial (R-bar) [m]")),
        (ax_yz, (y, z), ("y along-track (V-bar) [m]", "z orbit normal [m]")),
    ):
        ax.plot(h, v, color="tab:blue", lw=1.0, label="chaser")
        mark_start_end(ax, h, v)
        ax.plot([0.0], [0.0], "*", color="k", ms=11, label="target", zorder=4)
        if hold is not None:
            i_h, i_v = (1, 0) if ax is ax_yx else (1, 2)
            ax.plot(hold[:, i_h], hold[:, i_v], "--", color="tab:purple", lw=0.8)
            if len(holds):
                ax.plot(
                    holds[:, i_h],
                    holds[:, i_v],
                    "X",
                    color="tab:purple",
                    ms=9,
                    label="hold point",
                    zorder=5,
                )
        ax.set_xlabel(hl)
        ax.set_ylabel(vl)
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
    ax_yx.set_title("y-x plane (in-plane)")
    ax_yz.set_title("y-z plane (out-of-plane)")
    ax_yx.legend(loc="best", fontsize=8)
    ax_3d.plot(x, y, z, color="tab:blue", lw=1.0)
    mark_start_end(ax_3d, x, y, z)
    ax_3d.plot([0.0], [0.0], [0.0], "*", color="k", ms=11)
    if len(holds):
        ax_3d.plot(holds[:, 0], holds[:, 1], holds[:, 2], "X", color="tab:purple", ms=9)
    equal_aspect_3d(ax_3d, np.vstack([p, np.zeros((1, 3)), holds]))
    ax_3d.set_xlabel("x radial [m]")
    ax_3d.set_ylabel("y along-track [m]")
    ax_3d.set_zlabel("z normal [m]")
    ax_3d.set_title("3-D path in L")
    return fig


def _figure_trajectory_target_body(log: RunLog, title: str) -> Figure | None:
    p = log.p_TC_T()
    if not has_finite(p):
        return None
    t = log.t
    fig = Figure(figsize=(15, 6.4), dpi=DPI)
    fig.suptitle(
        figure_title(title, "Chaser in the target body frame (T): p_TC_T = R_IT^T R_IL p_LC_L")
    )
    gs = grid(fig, 3, 2, right=0.1, top=0.65, hspace=0.12, wspace=0.12, width_ratios=(1.3, 1.0))
    axes = [fig.add_subplot(gs[0, 0])]
    axes += [fig.add_subplot(gs[i, 0], sharex=axes[0]) for i in (1, 2)]
    for i, (ax, name) in enumerate(zip(axes, "xyz")):
        ax.plot(t, p[:, i], color=COMPONENT_COLOURS[i], lw=1.0)
        ax.set_ylabel(f"p_TC_T {name} [m]")
        ax.grid(True, alpha=0.3)
        if i < 2:
            ax.tick_params(labelbottom=False)
    axes[0].set_title("components vs time (rotating with the target)")
    axes[-1].set_xlabel(log.t_label)
    ax_3d = fig.add_subplot(gs[:, 1], projection="3d")
    ax_3d.plot(p[:, 0], p[:, 1], p[:, 2], color="tab:blue", lw=0.8)
    mark_start_end(ax_3d, p[:, 0], p[:, 1], p[:, 2])
    ax_3d.plot([0.0], [0.0], [0.0], "*", color="k", ms=11, label="target")
    equal_aspect_3d(ax_3d, np.vstack([p, np.zeros((1, 3))]))
    ax_3d.set_xlabel("x_T [m]")
    ax_3d.set_ylabel("y_T [m]")
    ax_3d.set_zlabel("z_T [m]")
    ax_3d.set_title("3-D path in T")
    ax_3d.legend(loc="upper left", fontsize=8)
    return fig


def _figure_thrust(log: RunLog, title: str) -> Figure | None:
    wrench = log.get("body_wrench")
    prop = log.get("propellant_kg")
    panels = []
    if has_finite(wrench):
        panels += [("force", wrench[:, 3:6]), ("torque", wrench[:, 0:3])]
    if has_finite(prop):  # the log's propellant_kg is already the mass used since t = 0
        panels.append(("propellant", prop))
    if not panels:
        return None
    t = log.t
    fig = Figure(figsize=(12, 2.6 * len(panels) + 1.2), dpi=DPI)
    fig.suptitle(figure_title(title, "Chaser body wrench (in C) and propellant"))
    gs = grid(fig, len(panels), 1, hspace=0.3)
    axes = []
    for i, (kind, values) in enumerate(panels):
        ax = fig.add_subplot(gs[i, 0], sharex=axes[0] if axes else None)
        axes.append(ax)
        if kind == "propellant":
            ax.plot(t, values, color="tab:orange", lw=1.2)
            ax.set_ylabel("propellant used [kg]")
            ax.set_title(f"propellant used (total {np.nanmax(values):.4g} kg)", fontsize=10)
        else:
            symbol, unit = ("f", "N") if kind == "force" else ("τ", "N m")
            t_env, y_env = envelope(t, values)
            for j, name in enumerate("xyz"):
                ax.plot(
                    t_env[:, j],
                    y_env[:, j],
                    color=COMPONENT_COLOURS[j],
                    lw=0.9,
                    label=f"{symbol}_{name}",
                )
            ax.set_ylabel(f"{kind} in C [{unit}]")
            ax.legend(loc="upper right", fontsize=8, ncol=3)
        ax.grid(True, alpha=0.3)
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel(log.t_label)
    return fig


def _figure_duty(log: RunLog, title: str) -> Figure | None:
    duty = log.get("thruster_duty")
    # Samples of thruster_on taken slower than the PWM slots alias with the pulse pattern (a
    # log at period boundaries sees only the last slot): prefer the per-period delivered duty.
    delivered = log.get("thruster_delivered_duty")
    on = delivered if has_finite(delivered) else log.get("thruster_on")
    duty = duty if has_finite(duty) else None
    on = on if has_finite(on) else None
    if duty is None and on is None:
        return None
    t = log.t
    panels = [p for p in (("duty", duty), ("on", on)) if p[1] is not None]
    fig = Figure(figsize=(12, 3.2 * len(panels) + 1.2), dpi=DPI)
    fig.suptitle(figure_title(title, "Thruster commands (thrusters K of the chaser)"))
    # A narrow column for colour bars, so every panel keeps the same time axis.
    gs = grid(fig, len(panels), 2, right=0.9, hspace=0.3, wspace=0.02, width_ratios=(1.0, 0.015))
    axes = []
    for i, (kind, values) in enumerate(panels):
        ax = fig.add_subplot(gs[i, 0], sharex=axes[0] if axes else None)
        axes.append(ax)
        n = values.shape[1]
        if kind == "duty" and n <= MAX_DUTY_LINES:
            t_env, y_env = envelope(t, values)
            for k in range(n):
                ax.plot(t_env[:, k], y_env[:, k], lw=0.9, label=f"k={k}", drawstyle="steps-post")
            ax.set_ylim(-0.05, 1.05)
            ax.set_ylabel("duty cycle [-]")
            ax.legend(loc="upper right", fontsize=8, ncol=min(n, 6))
            ax.grid(True, alpha=0.3)
        else:
            edges, cells = _block_mean(t, values, MAX_HEATMAP_COLUMNS)
            averaged = len(cells) < len(t)
            if kind == "duty":
                label = "mean duty [-]" if averaged else "duty [-]"
                heatmap(fig, ax, fig.add_subplot(gs[i, 1]), edges, cells, label, "viridis")
            elif delivered is not None:
                heatmap(
                    fig, ax, fig.add_subplot(gs[i, 1]), edges, cells, "delivered duty [-]", "Greys"
                )
            else:
                label = "fraction on [-]" if averaged else "on (1) / off (0)"
                heatmap(fig, ax, fig.add_subplot(gs[i, 1]), edges, cells, label, "Greys")
        if kind == "duty" and log.get("thruster_force_C") is not None:
            panel_title = f"throttle |f_k| / f_max per gimbaled thruster ({n} thrusters, no PWM)"
        elif kind == "duty":
            panel_title = f"commanded duty cycle per thruster ({n} thrusters)"
        elif delivered is not None:
            panel_title = (
                "delivered by PWM: ON slots per period / subdivisions "
                f"(mean {np.nanmean(values):.3f})"
            )
        else:
            panel_title = f"on/off pattern (on-time fraction {np.nanmean(values):.2f})"
        ax.set_title(panel_title, fontsize=10)
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel(log.t_label)
    return fig


def _figure_separation(log: RunLog, title: str) -> Figure | None:
    sep = log.get("separation_m")
    p = log.get("p_LC_L")
    rng = np.linalg.norm(p, axis=1) if p is not None else None
    sep = sep if has_finite(sep) else None
    rng = rng if has_finite(rng) else None
    if sep is None and rng is None:
        return None
    t = log.t
    fig = Figure(figsize=(12, 5.0), dpi=DPI)
    fig.suptitle(figure_title(title, "Separation and range between chaser and target"))
    ax = fig.add_subplot(grid(fig, 1, 1, top=0.5)[0, 0])
    if rng is not None:
        ax.plot(t, rng, color="tab:blue", lw=1.2, label="range |p_LC_L| (centre to centre)")
    if sep is not None:
        ax.plot(t, sep, color="tab:red", lw=1.2, label="separation (surface to surface)")
        i_min = int(np.nanargmin(sep))
        ax.plot(
            t[i_min],
            sep[i_min],
            "v",
            color="tab:red",
            ms=8,
            label=f"min separation {sep[i_min]:.3g} m at {log.when(i_min)}",
        )
    values = np.concatenate([a[np.isfinite(a)] for a in (sep, rng) if a is not None])
    lo, hi = values.min(), values.max()
    if lo > 0.0 and hi / lo >= 100.0:
        ax.set_yscale("log")
    elif lo <= 0.0:
        ax.axhline(0.0, color="k", lw=0.8, ls=":")
        # Contact or penetration: linear near zero, logarithmic above, when the run spans decades.
        linthresh = max(-lo, 1e-4 * hi, 1e-9)
        if hi / linthresh >= 100.0:
            ax.set_yscale("symlog", linthresh=linthresh)
            ax.set_ylim(2.0 * min(lo, -linthresh), 2.0 * hi)
    ax.set_xlabel(log.t_label)
    ax.set_ylabel("distance [m]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize=9)
    return fig


_FIGURES: dict[str, Callable[[RunLog, str], Figure | None]] = {
    "trajectory_lvlh.png": _figure_trajectory_lvlh,
    "trajectory_target_body.png": _figure_trajectory_target_body,
    "thrust.png": _figure_thrust,
    "duty.png": _figure_duty,
    "separation.png": _figure_separation,
}
assert tuple(_FIGURES) == FIGURE_NAMES


# --------------------------------------------------------------------------------------------
# Writing


def save_figure(fig: Figure, path: Path) -> None:
    """Renders fig as PNG to a temporary file beside path, then renames it over path (a reader
    never sees half a file; every rpod figure is written through here)."""
    FigureCanvasAgg(fig)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        with open(tmp, "xb") as f:
            fig.savefig(f, format="png", dpi=DPI)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def _plugin_figures(plugins: Iterable) -> tuple[dict, dict]:
    """(log shapes, figures) of the generic figures and the plug-ins' (module docstring)."""
    shapes, figures = {}, dict(_FIGURES)
    for plugin in plugins:
        for key, width in plugin.log_shapes.items():
            shapes.setdefault(key, width)
        try:
            drawn = plugin.run_figures()
        except Exception:  # a side output: a plug-in's broken figures never cost the others
            _logger.warning("plots: %s's figures unavailable", type(plugin).__name__, exc_info=True)
            continue
        for name, draw in drawn.items():
            if name in figures:
                _logger.warning(
                    "plots: %s draws %s, already drawn; skipped", type(plugin).__name__, name
                )
                continue
            figures[name] = draw
    return shapes, figures


def write_plots(
    log: Mapping[str, np.ndarray], out_dir: Path, title: str = "", plugins: Iterable | None = None
) -> list[Path]:
    """Writes the PNG figures of a run's log into out_dir (created if needed).

    Args:
        log: Time series keyed by name, time as the first axis (a dict, or an `np.load`ed npz):
            t (N) [s], p_LC_L (N, 3) [m], q_IT and q_IL (N, 4) (w, x, y, z), thruster_duty and
            thruster_on (N, n), body_wrench (N, 6) [N m, N] (torque then force, in C),
            propellant_kg (N), separation_m (N), optional hold_point_L (N, 3) and p_TC_T (N, 3);
            and the plug-ins' own keys (their `log_shapes`, documented in their figures
            modules). Any key may be missing; what cannot be drawn is skipped.
        out_dir: Output folder, e.g. runs/<scenario>/plots.
        title: Prefix of every figure's title, e.g. the scenario name.
        plugins: The controller plug-ins whose `run_figures()` are drawn too (None: every
            registered one, rpod.diagrams.controller_seam.controller_plugins()).

    Returns:
        The paths written, the generic figures first (`FIGURE_NAMES` order), then each
        plug-in's in its order (figures without data are not written).
    """
    if plugins is None:
        plugins = controller_seam.controller_plugins()
    shapes, figures = _plugin_figures(plugins)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    data = RunLog(log, shapes)
    written = []
    for name, make in figures.items():
        path = out_dir / name
        try:
            fig = make(data, title) if data.n else None
            if fig is None:
                path.unlink(missing_ok=True)  # no stale figure from an earlier run
                continue
            save_figure(fig, path)
            written.append(path)
        except Exception:  # a side output: never lose the others (see the module docstring)
            _logger.warning("plots: could not draw %s", name, exc_info=True)
            path.unlink(missing_ok=True)
    return written
