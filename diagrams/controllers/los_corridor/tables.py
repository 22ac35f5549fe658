"""Paper 004's campaigns beside the paper, for `rpod report`: Table 3 and the Monte Carlo set.

Owns: `campaign_table` (the plug-in's `campaign_table`), `table3_rows` (Table 3: r_sync, the hold
and r_min per (omega_t, a_max), a start inside and outside r_sync each), `monte_carlo_rows`
(Sec. 9's X_MC beside the analytical sets) and `controller_variants` (a campaign flying several
controllers on the same starts, one Monte Carlo each), over the rows of a campaign's store.
Does not own: the runs' classification and the sets (rpod.planners.reachability_mc,
rpod.planners.reachability), the report's formatting (rpod.scenarios.report) or the figures of
the sets (reachability_figures.py, monte_carlo_figures.py).
"""

import math

import numpy as np

from rpod.models.los_corridor import holding_range_m, sync_range_m

# Paper 004 Table 3: (omega_t deg/s, a_max m/s^2) -> (r_sync m, Hold, r_min m) as printed.
PAPER_TABLE_3 = {
    (1, 0.10): (656.6, "No", 0.0),
    (1, 0.05): (328.3, "No", 143.7),
    (1, 0.02): (131.3, "No", 145.3),
    (2, 0.10): (164.1, "No", 143.0),
    (2, 0.05): (82.1, "No", 141.9),
    (2, 0.02): (32.8, "No", 111.8),
    (3, 0.10): (73.0, "No", 138.2),
    (3, 0.05): (36.5, "No", 111.4),
    (3, 0.02): (14.6, "No", 67.1),
    (4, 0.10): (41.0, "No", 113.2),
    (4, 0.05): (20.5, "No", 67.3),
    (4, 0.02): (8.2, "No", 62.1),
    (5, 0.10): (26.3, "No", 75.0),
    (5, 0.05): (13.1, "No", 63.9),
    (5, 0.02): (5.3, "No", 51.1),
}


def _start_outcome(metrics: dict | None) -> str:
    """One start's cell: held or not, the violation (depth), the least range and whether the
    true shapes touched."""
    if not metrics:
        return "failed run"
    held = "hold" if metrics.get("los_held") else "no hold"
    depth = metrics.get("los_violation_depth_m") or 0.0
    violation = f"violated {depth:.2f} m" if depth > 0 else "0 violations"
    contact = ", CONTACT" if metrics.get("min_separation_m", 1.0) <= 0.0 else ""
    r_min = metrics.get("los_min_range_m", float("nan"))
    return f"{held}, {violation}, r_min {r_min:.1f} m{contact}"


def table3_rows(rows: list[dict]) -> list[list[str]] | None:
    """Paper 004 Table 3 beside this campaign: one line per (omega_t, a_max), the start inside
    and the start outside r_sync; None when the rows are not such a campaign."""
    cells: dict[tuple, dict] = {}
    for row in rows:
        overrides, metrics = row.get("overrides") or {}, row.get("metrics")
        spin = overrides.get("target.w_IT_T_deg_s")
        a_max = overrides.get("controller.a_max_m_s2")
        if spin is None or a_max is None or not metrics or "los_sync_range_m" not in metrics:
            continue
        key = (round(float(np.linalg.norm(spin)), 6), round(float(a_max), 6))
        where = "inside" if metrics["los_start_inside_sync_range"] else "outside"
        cells.setdefault(key, {})[where] = metrics
    if not cells:
        return None
    table = []
    for (omega, a_max), starts in sorted(cells.items()):
        r_sync = sync_range_m(a_max, math.radians(omega))
        paper = PAPER_TABLE_3.get((round(omega), round(a_max, 2)))
        paper_text = f"{paper[0]:.1f} / {paper[1]} / {paper[2]:.1f}" if paper else "-"
        table.append(
            [
                f"{omega:g}",
                f"{a_max:.2f}",
                f"{r_sync:.1f}",
                f"{holding_range_m(a_max, math.radians(omega)):.1f}",
                _start_outcome(starts.get("inside")),
                _start_outcome(starts.get("outside")),
                paper_text,
            ]
        )
    return table


# Overrides that place a run in the Monte Carlo (its combination and start), not its controller.
_PER_START = (
    "target.w_IT_T_deg_s",
    "controller.a_max_m_s2",
    "controller.hold_distance_m",
    "chaser.p_LC_L",
)


def controller_variants(rows: list[dict]) -> dict[str, list[dict]]:
    """The rows split by what else their overrides set, each group labelled by it ('defaults'
    for none): a campaign that flies two controllers on the same starts is two Monte Carlos."""
    groups: dict[tuple, list[dict]] = {}
    for row in rows:
        overrides = row.get("overrides") or {}
        key = tuple(sorted((k, repr(v)) for k, v in overrides.items() if k not in _PER_START))
        groups.setdefault(key, []).append(row)
    return {
        ", ".join(f"{k.removeprefix('controller.')}={v}" for k, v in key) or "defaults": group
        for key, group in groups.items()
    }


def monte_carlo_rows(rows: list[dict]) -> list[list[str]] | None:
    """One line per (omega_t, a_max) of a Monte Carlo campaign (more than two starts in some
    combination), or None (rpod.planners.reachability_mc.mc_report)."""
    from rpod.planners.reachability_mc import mc_outcomes, mc_report  # only for a report

    outcomes = mc_outcomes(rows)
    if not outcomes or max(len(feasible) for _, feasible in outcomes.values()) <= 2:
        return None
    table = []
    for record in mc_report(rows):
        feasible = sum(1 for start in record.starts if start.feasible)
        paper = record.paper_nominal_percent
        table.append(
            [
                f"{record.omega_deg:g}",
                f"{record.a_max_m_s2:.2f}",
                f"{feasible}/{len(record.starts)}",
                f"{record.mc_percent:.1f}",
                f"{record.nominal_percent:.1f} ({'-' if paper is None else f'{paper:.1f}'})",
                f"{record.stochastic_percent:.1f}",
                f"{record.robust_percent:.1f}",
                f"{record.nominal_not_mc} ({record.nominal_not_mc_extrapolated} extrapolated)",
            ]
        )
    return table


def campaign_table(rows: list[dict]) -> tuple[str, list[str], list[list[str]]] | None:
    """A campaign of LOS-corridor runs beside paper 004: its Monte Carlo set (Sec. 9, when
    a combination has more than two starts: monte_carlo_rows) or Table 3 (table3_rows).
    A campaign that flies several controller variants on the same starts (e.g.
    los_monte_carlo_paper) gets one block of Monte Carlo rows per variant."""
    variants = controller_variants(rows)
    table = []
    for label, group in variants.items():
        block = monte_carlo_rows(group)
        if block:
            table += [[label, *line] for line in block] if len(variants) > 1 else block
    if table:
        title = (
            "Paper 004 Sec. 9 beside this campaign: X_MC (the starts' outcomes by Sibson "
            "interpolation on the 300 x 300 grid) and the analytical sets, % of the cone "
            "(rpod.planners.reachability_mc):"
        )
        header = ["omega_t deg/s", "a_max m/s^2", "feasible starts", "X_MC %"]
        header += ["X_nom % (paper)", "X_stoch %", "X_rob %", "X_nom not in X_MC"]
        return title, ["controller variant", *header] if len(variants) > 1 else header, table
    table = table3_rows(rows)
    if not table:
        return None
    title = (
        "Paper 004 Table 3 beside this campaign (ours: r_sync exact, eq. 14, and beside it "
        "r_hold = a_max / omega_t^2 = r_sync / 2, the farthest a chaser at rest in the "
        "tumbling frame can stay; each start's outcome over the run; paper: r_sync / Hold / "
        "r_min as printed):"
    )
    header = ["omega_t deg/s", "a_max m/s^2", "r_sync m", "r_hold m"]
    header += ["start inside", "start outside"]
    return title, [*header, "paper 004"], table
