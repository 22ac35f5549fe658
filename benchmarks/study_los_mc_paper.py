"""Paper 004 Sec. 9's Monte Carlo with the paper's MPC as printed beside rpod's, on the same starts.

    python benchmarks/study_los_mc_paper.py RESULTS

RESULTS is a `rpod sweep los_monte_carlo_paper`: every 5th start of Sec. 9's 195 (39) in each of
the 20 combinations, flown with rpod's MPC (cases w*_a*) and with the paper's as printed (cases
w*_a*_paper; the campaign's header lists what differs): 1,560 runs. Both columns classify their
780 runs as Sec. 9 does (rpod.planners.reachability_mc), and X_MC is interpolated from the same
39 starts per combination, coarser than the 195-start X_MC of
benchmarks/results/los_monte_carlo.md. Writes benchmarks/results/los_monte_carlo_paper.md.
"""

import argparse
import pathlib
import sys

from machine import machine_line, with_notes, write_results  # benchmarks/machine.py

from rpod.planners import reachability_mc as mc
from rpod.scenarios.store import ResultStore

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "los_monte_carlo_paper.md"


PAPER_SUFFIX = "_paper"  # the campaign's cases flown with the paper's MPC
NOTES = "## What this says"  # the hand-written section of the results file, kept on a rerun


def _share(feasible: int, total: int) -> str:
    return f"{feasible}/{total} ({100.0 * feasible / total:.1f} %)" if total else "-"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", type=pathlib.Path, help="the campaign's output folder")
    args = parser.parse_args()
    with ResultStore.open_existing(args.results) as store:
        rows = store.rows()
    paper_rows = [row for row in rows if str(row.get("case_name", "")).endswith(PAPER_SUFFIX)]
    rpod_rows = [row for row in rows if not str(row.get("case_name", "")).endswith(PAPER_SUFFIX)]
    if len(rpod_rows) != len(paper_rows) or not rows:
        sys.exit(f"{len(paper_rows)} runs with the paper's MPC but {len(rpod_rows)} with rpod's")
    rpod, paper = mc.mc_report(rpod_rows), mc.mc_report(paper_rows)
    lines = [
        "# Paper 004 Sec. 9 with the paper's MPC as printed, beside rpod's (same starts)",
        "",
        (
            f"Machine: {machine_line()}; `rpod sweep los_monte_carlo_paper --out {args.results}`, "
            f"then `python benchmarks/study_los_mc_paper.py {args.results}`."
        ),
        "",
        (
            "Formulation. Both columns: Sec. 9's 20 combinations on the same 39 starts each (every "
            "5th of los_monte_carlo's 195; 780 runs each), at rest in the target frame, 400 s on J2 "
            "truth in the base scenario's 51.6 deg orbit, N_p = 20, R_du = diag(1e5, 1e4, 1e5), "
            "stopped at the first violation, feasible = no violation beyond 1e-3 m. 'paper': 11d "
            "hard and untightened at every step (j = 0 included), H itself as the close "
            "approach's reference, a failed QP following the whole last plan, no best-effort QP "
            "(campaign los_monte_carlo_paper). 'rpod': the defaults: 11d tightened by 0.1 m, a "
            "recovery funnel over 10 steps, the reference 10 s of travel ahead, a failed QP "
            "flying the best-effort QP (the corridor as an exact penalty), then at most 5 steps "
            "of the last plan, then the brake or the regime's command. X_MC: the 0/1 outcomes "
            "of the 39 starts Sibson-interpolated on Table 2's grid (% of the cone)."
        ),
        "",
        (
            "| omega_t (deg/s) | a_max (m/s^2) | r_sync (m) | feasible, paper | feasible, rpod "
            "| X_MC %, paper | X_MC %, rpod | X_nom % |"
        ),
        "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for a, b in zip(paper, rpod):
        assert (a.omega_deg, a.a_max_m_s2) == (b.omega_deg, b.a_max_m_s2)
        lines.append(
            f"| {a.omega_deg:g} | {a.a_max_m_s2:.2f} | {a.r_sync_m:.1f} | "
            f"{a.feasible_starts}/{len(a.starts)} | {b.feasible_starts}/{len(b.starts)} | "
            f"{a.mc_percent:.1f} | {b.mc_percent:.1f} | {a.nominal_percent:.1f} |"
        )
    total = sum(len(r.starts) for r in paper)
    lines += [
        "",
        (
            f"Totals: paper {_share(sum(r.feasible_starts for r in paper), total)}, rpod "
            f"{_share(sum(r.feasible_starts for r in rpod), total)} feasible."
        ),
        "",
        "By the holding condition (r_hold = r_sync / 2; benchmarks/results/los_monte_carlo.md):",
        "",
        "| band | paper | rpod |",
        "| --- | ---: | ---: |",
    ]
    paper_bands, rpod_bands = mc.holding_bands(paper), mc.holding_bands(rpod)
    for name in paper_bands:
        lines.append(f"| {name} | {_share(*paper_bands[name])} | {_share(*rpod_bands[name])} |")
    changed = [
        (a_start, b_start)
        for a, b in zip(paper, rpod)
        for a_start, b_start in zip(
            sorted(a.starts, key=lambda s: tuple(s.p_T)),
            sorted(b.starts, key=lambda s: tuple(s.p_T)),
        )
        if a_start.feasible != b_start.feasible
    ]
    only_rpod = sum(1 for a_start, _ in changed if not a_start.feasible)
    lines += [
        "",
        (
            f"Starts where the two disagree: {len(changed)} ({only_rpod} feasible with rpod's MPC "
            f"only, {len(changed) - only_rpod} with the paper's only)."
        ),
        "",
    ]
    for a_start, b_start in changed[:10]:
        lines.append(
            f"- {a_start.omega_deg:g} deg/s, {a_start.a_max_m_s2:.2f} m/s^2, start "
            f"({a_start.p_T[0]:.1f}, {a_start.p_T[1]:.1f}) m: paper {a_start.reason}; rpod "
            f"{b_start.reason}"
        )
    if len(changed) > 10:
        lines.append(f"- and {len(changed) - 10} more")
    write_results(RESULTS, with_notes(RESULTS, lines, NOTES))


if __name__ == "__main__":
    main()
