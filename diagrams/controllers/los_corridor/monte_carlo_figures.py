"""PNG figures of paper 004's Monte Carlo safe-start set X_MC (Secs. 10.4-10.5): Fig. 2, the
closed-loop outcome of every start for the 20 (omega_t, a_max), and Fig. 3, X_MC over the
nested certified sets at 2 deg/s, 0.10 m/s^2.

Owns: `figure_mc_maps`, `figure_mc_overlay` and `write_mc_figures`. Does not own the runs'
classification or the interpolation (rpod.planners.reachability_mc), the certified sets
(rpod.planners.reachability) or the tables (benchmarks/los_monte_carlo_report.py).
matplotlib through `Figure` and the Agg canvas, never pyplot (no global state).

Colours: starts green (feasible) / red (infeasible), as the paper's Fig. 2; X_MC pale yellow,
nominal green, stochastic blue, robust purple (reachability_figures.py's); grid
points of X_nom outside X_MC (the exceptions to eq. 15) solid red; r_sync dotted.
"""

from __future__ import annotations

import math
import pathlib

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from rpod.diagrams.plots import save_figure
from rpod.planners import reachability as reach
from rpod.planners import reachability_mc as mc

_DPI = 110
_FEASIBLE, _INFEASIBLE = "#2ca02c", "#d62728"
# Fig. 2's background: outside the cone, the cone, X_MC.
_MAP_LEVELS = ListedColormap(["white", "0.90", "#dff0d8"])
# Fig. 3's: outside, cone, X_MC, X_nom, X_stoch, X_rob, X_nom outside X_MC.
_OVERLAY_LEVELS = ListedColormap(
    ["white", "0.88", "#f6e7a1", "#5cb85c", "#4a7fd0", "#8e44ad", "#d62728"]
)
OVERLAY_COMBINATION = (2.0, 0.10)  # Fig. 3


def _image(ax, grid: reach.SafeStartGrid, level: np.ndarray, cmap, vmax: int) -> None:
    extent = (grid.x_m[0], grid.x_m[-1], grid.y_m[0], grid.y_m[-1])
    ax.imshow(
        level.reshape(len(grid.y_m), len(grid.x_m)),
        origin="lower",
        extent=extent,
        cmap=cmap,
        vmin=0,
        vmax=vmax,
        interpolation="nearest",
    )
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(0.0, grid.y_max_m)
    ax.set_aspect("equal")


def _outline(ax, grid: reach.SafeStartGrid, mask: np.ndarray, colour: str, lw: float) -> None:
    """The edge of a set on the grid (nothing for an empty or full one)."""
    if mask.any() and not mask.all():
        shape = (len(grid.y_m), len(grid.x_m))
        ax.contour(
            grid.x_m,
            grid.y_m,
            mask.reshape(shape).astype(float),
            [0.5],
            colors=colour,
            linewidths=lw,
        )


def _sync_arc(ax, record: mc.McCombination) -> None:
    if record.r_sync_m < record.grid.y_max_m * 1.2:
        t = np.linspace(-math.pi / 6, math.pi / 6, 60)
        ax.plot(record.r_sync_m * np.sin(t), record.r_sync_m * np.cos(t), "k:", lw=0.8)


def _starts(ax, record: mc.McCombination, size: float) -> None:
    sites, ok = record.sites_xy, record.feasible
    for mask, colour in ((ok, _FEASIBLE), (~ok, _INFEASIBLE)):
        ax.scatter(sites[mask, 0], sites[mask, 1], s=size, c=colour, edgecolors="k", linewidths=0.3)


def figure_mc_maps(records: list[mc.McCombination]) -> Figure:
    """Fig. 2: one panel per combination (omega_t down, a_max across): the starts green or red
    over the cone, X_MC shaded, r_sync dotted."""
    by_key = {(r.omega_deg, r.a_max_m_s2): r for r in records}
    omegas = sorted({k[0] for k in by_key})
    a_maxes = sorted({k[1] for k in by_key}, reverse=True)
    rows, cols = len(omegas), len(a_maxes)
    fig = Figure(figsize=(3.1 * cols, 3.0 * rows + 0.4), dpi=_DPI)
    for i, w in enumerate(omegas):
        for j, a in enumerate(a_maxes):
            record = by_key.get((w, a))
            if record is None:
                continue
            ax = fig.add_subplot(rows, cols, i * cols + j + 1)
            level = record.grid.inside.astype(int) + record.masks["mc"]
            _image(ax, record.grid, level, _MAP_LEVELS, 2)
            _outline(ax, record.grid, record.masks["nominal"], "#2e7d32", 0.8)
            _sync_arc(ax, record)
            _starts(ax, record, 9.0)
            ax.set_title(
                f"{w:g} deg/s, {a:.2f} m/s$^2$: {record.feasible_starts}/{len(record.starts)}, "
                f"X_MC {record.mc_percent:.1f} %",
                fontsize=8,
            )
            ax.tick_params(labelsize=7)
            if j == 0:
                ax.set_ylabel("$y_T$ (m)", fontsize=8)
            if i == rows - 1:
                ax.set_xlabel("$x_T$ (m)", fontsize=8)
    fig.suptitle(
        "Monte Carlo starts on z_T = 0, closed loop: feasible (green) / infeasible (red)\n"
        "X_MC (natural-neighbour interpolation) shaded, X_nom outlined, r_sync dotted",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 1.0 - 0.7 / fig.get_figheight()))
    return fig


def figure_mc_overlay(record: mc.McCombination) -> Figure:
    """Fig. 3: X_MC, X_nom, X_stoch and X_rob of one combination, the starts on top; grid
    points of X_nom outside X_MC in solid red; each set's edge outlined in a darker shade."""
    m = record.masks
    level = np.where(record.grid.inside, 1, 0)
    level = np.where(m["mc"], 2, level)
    level = np.where(m["nominal"], 3, level)
    level = np.where(m["stochastic"], 4, level)
    level = np.where(m["robust"], 5, level)
    level = np.where(m["nominal"] & ~m["mc"], 6, level)
    fig = Figure(figsize=(10.0, 5.6), dpi=_DPI, layout="constrained")  # room for the legend
    ax = fig.add_subplot(1, 1, 1)
    _image(ax, record.grid, level, _OVERLAY_LEVELS, 6)
    colours = _OVERLAY_LEVELS.colors
    for name, colour in (("mc", "#b08d00"), ("nominal", "#2e7d32"), ("stochastic", "#1f4e9c")):
        _outline(ax, record.grid, m[name], colour, 0.9)
    _outline(ax, record.grid, m["robust"], "#5b1f78", 0.9)
    _sync_arc(ax, record)
    _starts(ax, record, 22.0)
    handles = [
        Patch(color=colours[2], label=f"X_MC ({record.mc_percent:.1f} % of the cone)"),
        Patch(color=colours[3], label=f"X_nom ({record.nominal_percent:.1f} %)"),
        Patch(color=colours[4], label=f"X_stoch ({record.stochastic_percent:.1f} %)"),
        Patch(color=colours[5], label=f"X_rob ({record.robust_percent:.1f} %)"),
        Patch(color=colours[6], label=f"X_nom outside X_MC ({record.nominal_not_mc} points)"),
        ax.scatter([], [], s=22, c=_FEASIBLE, edgecolors="k", linewidths=0.3, label="feasible"),
        ax.scatter([], [], s=22, c=_INFEASIBLE, edgecolors="k", linewidths=0.3, label="infeasible"),
    ]
    ax.legend(handles=handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_xlabel("$x_T$ (m)")
    ax.set_ylabel("$y_T$ (m)")
    ax.set_title(
        f"{record.omega_deg:g} deg/s, {record.a_max_m_s2:.2f} m/s$^2$: X_MC vs nominal vs "
        f"stochastic vs robust (r_sync {record.r_sync_m:.0f} m, dotted)",
        fontsize=10,
    )
    return fig


def write_mc_figures(
    rows: list[dict],
    out_dir: pathlib.Path,
    records: list[mc.McCombination] | None = None,
    prefix: str = "los_monte_carlo",
) -> list[pathlib.Path]:
    """Writes <prefix>_maps.png (Fig. 2) and, when the campaign has 2 deg/s, 0.10 m/s^2,
    <prefix>_overlay.png (Fig. 3) into out_dir; the paths written.

    Args:
        rows: `ResultStore.rows()` of the campaign.
        out_dir: The folder (made if missing).
        records: `mc_report(rows)` when already computed.
        prefix: The files' common name.
    """
    records = mc.mc_report(rows) if records is None else records
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    if records:
        paths.append(out_dir / f"{prefix}_maps.png")
        save_figure(figure_mc_maps(records), paths[-1])
    overlay = next((r for r in records if (r.omega_deg, r.a_max_m_s2) == OVERLAY_COMBINATION), None)
    if overlay is not None:
        paths.append(out_dir / f"{prefix}_overlay.png")
        save_figure(figure_mc_overlay(overlay), paths[-1])
    return paths
