"""PNG figures of paper 004's safe-start analysis (Secs. 8-11), from rpod.planners.reachability's
sets: the nested regions of the 20 combinations (Fig. 1's layout) and the collapse of the safe
fraction against a_max / omega_t^2 (Sec. 11.2).

Owns: `figure_nested_regions`, `figure_collapse` and `write_reachability_figures`. Does not own
the sets (rpod.planners.reachability) or the tables (benchmarks/bench_reachability.py).
matplotlib through `Figure` and the Agg canvas, never pyplot (no global state).

Colours: nominal green, stochastic blue, robust purple (the paper's Fig. 1); the cone grey; the
backward kernel's polygon as outlines, from rest in T dashed and from rest in I solid.
"""

from __future__ import annotations

import math
import pathlib

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from rpod.diagrams.plots import save_figure
from rpod.planners import reachability as reach

_DPI = 110
_LEVELS = ListedColormap(["white", "0.88", "#5cb85c", "#4a7fd0", "#8e44ad"])  # out .. robust
_KERNEL_STYLE = {"corotating": ("k", "--"), "inertial": ("k", "-")}


def figure_nested_regions(grid: reach.SafeStartGrid, masks: dict, polygons: dict) -> Figure:
    """5 x 4 panels (omega_t down, a_max across): cone, X_nom, X_stoch, X_rob filled, the
    kernels outlined.

    Args:
        grid: The grid the masks are on.
        masks: {(omega_deg, a_max): {"nominal", "stochastic", "robust": (K,) bool}}.
        polygons: {(omega_deg, a_max, start): SupportPolygon} (optional entries).
    """
    rows, cols = len(reach.OMEGA_T_DEG_S), len(reach.A_MAX_M_S2)
    fig = Figure(figsize=(3.1 * cols, 3.0 * rows), dpi=_DPI)
    shape = (len(grid.y_m), len(grid.x_m))
    extent = (grid.x_m[0], grid.x_m[-1], grid.y_m[0], grid.y_m[-1])
    for i, w in enumerate(reach.OMEGA_T_DEG_S):
        for j, a in enumerate(reach.A_MAX_M_S2):
            ax = fig.add_subplot(rows, cols, i * cols + j + 1)
            m = masks[(w, a)]
            level = grid.inside.astype(int) + m["nominal"] + m["stochastic"] + m["robust"]
            ax.imshow(
                level.reshape(shape),
                origin="lower",
                extent=extent,
                cmap=_LEVELS,
                vmin=0,
                vmax=4,
                interpolation="nearest",
            )
            for start, (colour, style) in _KERNEL_STYLE.items():
                polygon = polygons.get((w, a, start))
                if polygon is not None and len(polygon.vertices) >= 3:
                    closed = np.vstack([polygon.vertices, polygon.vertices[:1]])
                    ax.plot(closed[:, 0], closed[:, 1], color=colour, ls=style, lw=0.9)
            r_sync = reach.sync_range_m(a, math.radians(w))
            if r_sync < grid.y_max_m * 1.2:
                t = np.linspace(-math.pi / 6, math.pi / 6, 50)
                ax.plot(r_sync * np.sin(t), r_sync * np.cos(t), color="0.4", lw=0.6, ls=":")
            ax.set_xlim(extent[0], extent[1])
            ax.set_ylim(0.0, grid.y_max_m)
            ax.set_aspect("equal")
            ax.set_title(f"{w:.0f} deg/s, {a:.2f} m/s$^2$", fontsize=9)
            ax.tick_params(labelsize=7)
            if j == 0:
                ax.set_ylabel("$y_T$ (m)", fontsize=8)
            if i == rows - 1:
                ax.set_xlabel("$x_T$ (m)", fontsize=8)
    fig.suptitle(
        "Safe starts on z_T = 0: nominal (green) > stochastic (blue) > robust (purple); backward "
        "kernel, rest in T (dashed), rest in I (solid); r_sync dotted",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    return fig


def figure_collapse(fractions: dict) -> Figure:
    """Safe fraction against a_max / omega_t^2 (log) for each family, one marker per omega_t.

    Args:
        fractions: {(omega_deg, a_max): {"nominal", "stochastic", "robust", "corotating",
            "inertial": %}}.
    """
    fig = Figure(figsize=(10, 5.5), dpi=_DPI)
    ax = fig.add_subplot(1, 1, 1)
    families = {
        "nominal": ("#5cb85c", "nominal (eqs. 13, 14, 16)"),
        "robust": ("#8e44ad", "robust"),
        "corotating": ("k", "backward kernel, rest in T"),
        "inertial": ("0.5", "backward kernel, rest in I"),
    }
    markers = dict(zip(reach.OMEGA_T_DEG_S, "osD^v"))
    for family, (colour, label) in families.items():
        keys = sorted(fractions, key=lambda k: k[1] / math.radians(k[0]) ** 2)
        scale = [k[1] / math.radians(k[0]) ** 2 for k in keys]
        ax.plot(scale, [fractions[k][family] for k in keys], color=colour, lw=0.6, alpha=0.5)
        for k, s in zip(keys, scale):
            ax.plot(s, fractions[k][family], marker=markers[k[0]], color=colour, ls="none")
        ax.plot([], [], color=colour, lw=2, label=label)
    paper = [(k[1] / math.radians(k[0]) ** 2, v) for k, v in reach.PAPER_TABLE_2.items()]
    ax.plot(*zip(*paper), "x", color="r", label="paper, Table 2")
    for w, m in markers.items():
        ax.plot([], [], marker=m, color="0.3", ls="none", label=f"{w:.0f} deg/s")
    ax.set_xscale("log")
    ax.set_xlabel("a_max / omega_t^2 (m)")
    ax.set_ylabel("safe fraction of the cone (%)")
    ax.set_ylim(-2, 102)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title("Sec. 11.2: the forward sets collapse onto one curve; the 20 s kernel does not")
    fig.tight_layout()
    return fig


def write_reachability_figures(
    out_dir: pathlib.Path, grid, masks: dict, polygons: dict, fractions: dict
) -> list[pathlib.Path]:
    """Writes reachability_regions.png and reachability_collapse.png into out_dir."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [out_dir / "reachability_regions.png", out_dir / "reachability_collapse.png"]
    save_figure(figure_nested_regions(grid, masks, polygons), paths[0])
    save_figure(figure_collapse(fractions), paths[1])
    return paths
