"""Paper 004's Monte Carlo safe-start set X_MC (Secs. 9, 10.4-10.5) from a campaign's store,
beside the certified sets: Fig. 2, Fig. 3 and the check X_nom within X_MC (eq. 15).

    python benchmarks/los_monte_carlo_report.py RESULTS_DIR [--out-dir DIR]

Reads RESULTS_DIR/results.sqlite (a `rpod sweep` of the 20 x 195 starts of Sec. 9, each
setting target.w_IT_T_deg_s, controller.a_max_m_s2 and chaser.p_LC_L) and writes
los_monte_carlo.md, los_monte_carlo_maps.png (Fig. 2) and los_monte_carlo_overlay.png (Fig. 3)
into benchmarks/results/ (or --out-dir). The classification, the interpolation and the
attribution of the exceptions are rpod.planners.reachability_mc's (its module docstring).
"""

import argparse
import datetime
import math
import os
import pathlib
import sys
import time

from machine import machine_line  # benchmarks/machine.py, beside this script

from rpod.diagrams.controllers.los_corridor.monte_carlo_figures import write_mc_figures
from rpod.planners import reachability_mc as mc
from rpod.scenarios.store import ResultStore

RESULTS_DIR = pathlib.Path(__file__).resolve().parent / "results"
NAME = "los_monte_carlo"
MAX_LISTED = 5  # exceptions listed per combination


def pct(x: float | None) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.1f}"


def where(p) -> str:
    return f"({p[0]:.1f}, {p[1]:.1f})"


def hours(seconds: float) -> str:
    return f"{seconds / 3600.0:.2f} h" if seconds >= 3600.0 else f"{seconds / 60.0:.1f} min"


def wall_times(rows: list[dict]) -> tuple[float, float | None]:
    """(the runs' summed wall time [s], the span from the first to the last finish [s])."""
    total = 0.0
    for row in rows:
        w = row.get("wall_time_s")
        if w is None and row.get("metrics"):
            w = row["metrics"].get("wall_time_s")
        total += float(w or 0.0)
    stamps = [
        datetime.datetime.fromisoformat(r["finished_at"]) for r in rows if r.get("finished_at")
    ]
    span = (max(stamps) - min(stamps)).total_seconds() if len(stamps) > 1 else None
    return total, span


def contingency(records) -> dict[tuple[bool, bool], int]:
    """{(certified at the start, feasible): count} over all the campaign's starts."""
    out = {(c, f): 0 for c in (True, False) for f in (True, False)}
    for r in records:
        for certified, feasible in zip(r.start_certified, r.feasible):
            out[(bool(certified), bool(feasible))] += 1
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results_dir", type=pathlib.Path, help="the campaign's output folder")
    parser.add_argument("--out-dir", type=pathlib.Path, default=RESULTS_DIR)
    args = parser.parse_args()
    load = os.getloadavg()
    with ResultStore.open_existing(args.results_dir) as store:
        rows, meta, counts = store.rows(), store.meta(), store.counts()
    duration = mc.campaign_duration_s(rows)
    start = time.perf_counter()
    records = mc.mc_report(rows)
    analysis_s = time.perf_counter() - start
    if not records:
        sys.exit(f"{args.results_dir}: no run sets target.w_IT_T_deg_s, a_max and p_LC_L")
    start = time.perf_counter()
    figures = write_mc_figures(rows, args.out_dir, records, prefix=NAME)
    figures_s = time.perf_counter() - start
    total_wall, span = wall_times(rows)
    grid = records[0].grid

    lines = [
        "# Paper 004's Monte Carlo safe-start set X_MC beside the certified sets (Secs. 9-10)",
        "",
        (
            f"Machine: {machine_line()}; `python benchmarks/los_monte_carlo_report.py "
            f"{args.results_dir}`; 1-minute load average {load[0]:.2f} at the start."
        ),
        "",
        f"Campaign `{meta.get('campaign_name', '?')}` ({meta.get('campaign_source', '?')}): "
        f"{sum(counts.values())} runs planned, {counts['ok']} ok, {counts['failed']} failed, "
        f"{counts['pending']} pending; the runs' summed wall time {hours(total_wall)}"
        + (f", first to last finish {hours(span)}" if span is not None else "")
        + (f"; simulated {duration:.0f} s each (the longest run)." if duration else "."),
        "",
        (
            "Formulation: rpod's MPC, not the paper's as printed (README, 'LOS corridor'): 11d "
            "tightened by 0.1 m at every predicted step, a recovery funnel over 10 steps for a "
            "chaser outside, the close approach's reference 10 s of travel ahead of the chaser "
            "(the paper tracks H), the input weight centred on the regime's command, a failed QP "
            "flying the best-effort QP (the corridor as an exact penalty) then at most 5 steps "
            "of the last plan; N_p = 20, R_du = diag(1e5, 1e4, 1e5); J2 truth in the base "
            "scenario's 51.6 deg, 500 km orbit. The paper's MPC as printed on a 1-in-5 subsample: "
            "benchmarks/results/los_monte_carlo_paper.md."
        ),
        "",
        (
            "Classification (rpod.planners.reachability_mc, choice 1): feasible = the run finished, "
            "no corridor violation deeper than 1e-3 m, and it flew the whole duration; a failed run, "
            "a run stopped at its first violation or any early end is infeasible (the paper's "
            "'early termination'). A QP that OSQP did not solve is not a failure by itself: the "
            "controller flies a checked fallback, and only what the chaser did counts. X_MC: the "
            "0/1 outcomes Sibson-interpolated (exact natural-neighbour weights) onto the "
            f"{len(grid.x_m)} x {len(grid.y_m)} grid of Table 2 (y_T to {grid.y_max_m:.0f} m), "
            "nearest start outside the starts' hull, above 0.5; a share is of the grid's "
            f"{int(grid.inside.sum())} in-cone points. Certified sets: rpod.planners.reachability "
            f"(NoiseModel defaults). Analysis {analysis_s:.2f} s for all combinations, figures "
            f"{figures_s:.1f} s."
        ),
        "",
        "## Per combination",
        "",
        (
            "| omega_t (deg/s) | a_max (m/s^2) | r_sync (m) | feasible starts | failed runs | "
            "X_MC % | nominal %, ours / paper | stochastic % | robust % | X_nom not in X_MC "
            "(grid points; of which beyond the starts' hull) | certified starts that failed |"
        ),
        "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in records:
        lines.append(
            f"| {r.omega_deg:g} | {r.a_max_m_s2:.2f} | {r.r_sync_m:.1f} | "
            f"{r.feasible_starts}/{len(r.starts)} | {r.failed_runs} | {pct(r.mc_percent)} | "
            f"{pct(r.nominal_percent)} / {pct(r.paper_nominal_percent)} | "
            f"{pct(r.stochastic_percent)} | {pct(r.robust_percent)} | {r.nominal_not_mc} ({r.nominal_not_mc_extrapolated}) | "
            f"{len(r.nominal_starts_infeasible)}/{r.nominal_starts} |"
        )
    starts = sum(len(r.starts) for r in records)
    feasible = sum(r.feasible_starts for r in records)
    exceptions = sum(r.nominal_not_mc for r in records)
    clean = sum(r.nominal_not_mc == 0 for r in records)
    failed_certified = sum(len(r.nominal_starts_infeasible) for r in records)
    certified = sum(r.nominal_starts for r in records)
    table = contingency(records)
    lines += [
        "",
        (
            f"Totals: {len(records)} combinations, {feasible}/{starts} starts feasible "
            f"({100.0 * feasible / starts:.1f} %), {sum(r.failed_runs for r in records)} failed "
            f"runs. X_nom within X_MC at every grid point in {clean} of {len(records)} "
            f"combinations; {exceptions} grid points of X_nom outside X_MC in all "
            f"({100.0 * exceptions / (grid.inside.sum() * len(records)):.2f} % of the cones). "
            f"X_stoch not in X_MC: {sum(r.stochastic_not_mc for r in records)}; X_rob not in X_MC: "
            f"{sum(r.robust_not_mc for r in records)} grid points."
        ),
        "",
        (
            "The starts themselves against criterion (16) with eq. 14 at their own positions: "
            f"certified and feasible {table[(True, True)]}, certified and infeasible "
            f"{table[(True, False)]} (of {certified} certified), uncertified and feasible "
            f"{table[(False, True)]}, uncertified and infeasible {table[(False, False)]}."
        ),
        "",
        "## Paper 004's conclusion 5 against the holding condition",
        "",
        (
            "Conclusion 5 says a start inside r_sync = 2 a_max / omega_t^2 (eq. 14) can be "
            "brought to the hold. r_sync is the braking condition: a chaser at rest in the "
            "tumbling frame can brake its apparent speed omega_t r within r. Staying there asks "
            "for the centripetal omega_t^2 r <= a_max, i.e. r <= r_hold = r_sync / 2 "
            "(rpod.models.los_corridor.holding_range_m). The starts by band, feasible / all:"
        ),
        "",
        "| band | feasible starts | share |",
        "| --- | ---: | ---: |",
        *[
            f"| {name} | {feasible}/{total} | "
            f"{(100.0 * feasible / total if total else math.nan):.1f} % |"
            for name, (feasible, total) in mc.holding_bands(records).items()
        ],
        "",
        "## X_nom within X_MC: the exceptions",
        "",
        (
            "Each grid point of X_nom outside X_MC is blamed on its nearest infeasible start. "
            "'certified start' means the start itself satisfies (16) with (14): a certified start "
            "that failed in closed loop is a true counterexample to eq. 15. An uncertified start "
            "means the interpolation carried a failure outside X_nom across X_nom's edge: 195 "
            "starts 20 m apart in y_T (up to 27 m in x_T) cannot draw an edge finer than that, "
            "and even an exact oracle (feasible iff certified) leaves such points (the tests, "
            "test_certified_outcome_smears_across_the_edge)."
        ),
        "",
    ]
    if exceptions == 0 and failed_certified == 0:
        lines.append("None: X_nom lies within X_MC at every grid point of every combination.")
    for r in records:
        if not r.exceptions and not r.nominal_starts_infeasible:
            continue
        lines += [f"### {r.omega_deg:g} deg/s, {r.a_max_m_s2:.2f} m/s^2", ""]
        for e in r.exceptions[:MAX_LISTED]:
            kind = "certified start" if e.start_in_nominal else "uncertified start"
            lines.append(
                f"- {e.grid_points} grid points: nearest failure at {where(e.start.p_T)} m "
                f"({kind}, run {e.start.run_id}): {e.start.reason}"
            )
        if len(r.exceptions) > MAX_LISTED:
            rest = r.exceptions[MAX_LISTED:]
            lines.append(
                f"- and {len(rest)} more starts ({sum(e.grid_points for e in rest)} points)"
            )
        blamed = {e.start.run_id for e in r.exceptions[:MAX_LISTED]}
        for s in r.nominal_starts_infeasible:
            if s.run_id not in blamed:
                lines.append(
                    f"- certified start {where(s.p_T)} m failed (run {s.run_id}; no grid point "
                    f"of X_nom lost to it): {s.reason}"
                )
        lines.append("")
    lines += [
        "## Figures",
        "",
        *[f"- `{p.name}`" for p in figures],
        "",
        (
            "Fig. 2 (maps): per combination the starts, green feasible and red infeasible, over the "
            "cone with X_MC shaded and r_sync dotted. Fig. 3 (overlay, 2 deg/s, 0.10 m/s^2): X_MC "
            "(pale yellow), X_nom (green), X_stoch (blue), X_rob (purple), X_nom outside X_MC (red)."
        ),
        "",
    ]
    args.out_dir.mkdir(parents=True, exist_ok=True)
    out = args.out_dir / f"{NAME}.md"
    out.write_text("\n".join(lines))
    print("\n".join(lines))
    print(f"wrote {out} and {', '.join(str(p) for p in figures)}", file=sys.stderr)


if __name__ == "__main__":
    main()
