"""Paper 003's campaign maps (Figs. 8-9-like), for `rpod report` and the benchmark.

Owns: `write_campaign_maps`. Does not own: which rows are a planar campaign's ok runs
(tables.metric_rows), the run figures (figures.py) or writing a PNG (plots.save_figure).

Campaign maps (`write_campaign_maps`, for `rpod report` and the benchmark; rows are the ok runs'
metrics, i.e. summary.json dicts): for a campaign over omega_target and F_thr (Case Study 1)
`planar_case1.png` (Fig. 8: stacked shares of the three terms of J (eq. 5) per omega, averaged
over F_thr, with the mean +- std of the planned final position error) and heat maps of the
planned final position error, the flown RMS tracking error and the safe runs (planned, no
contact) over the grid; for one over theta_approach and omega (Case Study 2) `planar_case2.png`
(Fig. 9: a polar plot of the planned final error against theta_approach, one series per omega,
and the same heat maps over (theta_approach, omega)). A cell with no ok run is blank.
"""

from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure

from rpod.diagrams.plots import DPI, save_figure


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
