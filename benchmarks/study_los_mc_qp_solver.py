"""Paper 004's Monte Carlo flown with another QP solver: steps without a usable input, outcomes.

    rpod sweep benchmarks/campaigns/los_monte_carlo_daqp.yaml --out runs/lmc_daqp
    rpod sweep benchmarks/campaigns/los_monte_carlo_osqp_1in5.yaml --out runs/lmc_osqp
    python benchmarks/study_los_mc_qp_solver.py runs/lmc_daqp runs/lmc_osqp

Issue 23's goal for paper 004's MPC: zero steps without a usable input over the 3,900-run Monte
Carlo. A step without a usable input is one where no QP gave an input when one was due and the
controller flew the previous plan or the brake (the seam's `solver_failures`; a best-effort QP
outside the corridor and the far command are fallbacks by design, not failures), counted by
the hard QP's status at that step (`los_no_input_by_status`). For each store:
runs, Sec. 9's classification (rpod.planners.reachability_mc, choice 1), the summed
`solver_failures`, `los_qp_not_solved` and `los_fallback_steps`, and the per-step compute (the
controller's step timer: the worst run's p99 and max). Then the two solvers on the starts both
flew (matched by case and start): how many outcomes agree, and every start where they do not.
Writes benchmarks/results/los_monte_carlo_qp_solvers.md (its hand-written section is kept).
"""

import argparse
import json
import pathlib

import numpy as np
from machine import machine_line, with_notes, write_results  # benchmarks/machine.py

from rpod.planners import reachability_mc as mc
from rpod.scenarios.report import read_results

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "los_monte_carlo_qp_solvers.md"
NOTES = "## What this says"  # the hand-written section, kept on a rerun


def _read(folder: pathlib.Path) -> tuple[dict, list[dict]]:
    """(meta, finished rows) of a store."""
    meta, rows = read_results(folder)
    return meta, [row for row in rows if row["status"] != "pending"]


def _solver(meta: dict) -> str:
    """The QP solver a campaign's overrides chose (OSQP when none did)."""
    text = meta.get("campaign_text", "")
    for line in text.splitlines():
        setting = line.split("#", 1)[0]  # not the files' comments
        if "controller.mpc.qp_solver:" in setting:
            return setting.split(":", 1)[1].strip()
    return "osqp"


def _sum(rows, key) -> int:
    return int(sum((row["metrics"] or {}).get(key) or 0 for row in rows))


def _worst(rows, key) -> float:
    values = [(row["metrics"] or {}).get(key) for row in rows]
    values = [v for v in values if v is not None]
    return float(max(values)) if values else float("nan")


def _start(row: dict) -> tuple[str, str]:
    return row["case_name"], json.dumps(row["overrides"].get("chaser.p_LC_L"))


def summary_row(label: str, rows: list[dict]) -> list:
    duration = mc.campaign_duration_s(rows)
    feasible = sum(mc.classify_run(row, duration)[0] for row in rows)
    ok = [row for row in rows if row["status"] == "ok"]
    no_input_runs = sum(bool((row["metrics"] or {}).get("solver_failures")) for row in ok)
    return [
        label,
        len(rows),
        sum(row["status"] != "ok" for row in rows),
        f"{feasible} ({100.0 * feasible / len(rows):.1f} %)",
        f"{_sum(ok, 'solver_failures')} in {no_input_runs} runs",
        _sum(ok, "los_qp_not_solved"),
        _sum(ok, "los_fallback_steps"),
        f"{np.median([r['metrics']['control_step_ms_p50'] for r in ok]):.3f}",
        f"{_worst(ok, 'control_step_ms_p99'):.2f}",
        f"{_worst(ok, 'control_step_ms_max'):.2f}",
    ]


def status_lines(flown) -> list[str]:
    """The steps without a usable input by the hard QP's status (los_no_input_by_status): a
    primal-infeasible verdict certifies that no input kept the corridor; the others do not."""
    totals = []
    for solver, folder, rows in flown:
        total: dict[str, int] = {}
        for row in rows:
            for key, count in ((row["metrics"] or {}).get("los_no_input_by_status") or {}).items():
                total[key] = total.get(key, 0) + count
        totals.append((f"{solver} ({folder.name})", total))
    keys = sorted({key for _, total in totals for key, count in total.items() if count})
    if not any(total for _, total in totals):
        return ["(The stores' summaries hold no los_no_input_by_status: flown before it.)"]
    lines = [
        (
            "Steps without a usable input by the hard QP's status at that step (far_: the far "
            "regime, which has no best-effort QP; skipped: the hard QP not tried beyond one "
            "step of the corridor):"
        ),
        "",
        "| solver (campaign) | " + " | ".join(keys) + " |",
        "| --- | " + " | ".join("---:" for _ in keys) + " |",
    ]
    for label, total in totals:
        lines.append(f"| {label} | " + " | ".join(str(total.get(key, 0)) for key in keys) + " |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("stores", type=pathlib.Path, nargs="+", help="campaign output folders")
    args = parser.parse_args()
    flown = [
        (_solver(meta), folder, rows) for folder in args.stores for meta, rows in [_read(folder)]
    ]
    header = [
        "solver (campaign)",
        "runs",
        "sim failed",
        "feasible (Sec. 9)",
        "steps without a usable input",
        "QPs not solved",
        "steps on a fallback",
        "step p50 ms (median run)",
        "step p99 ms (worst run)",
        "step max ms (worst run)",
    ]
    table = [summary_row(f"{solver} ({folder.name})", rows) for solver, folder, rows in flown]
    lines = [
        "# Paper 004's Monte Carlo with the MPC's QP solved by DAQP and by OSQP (issue 23)",
        "",
        f"Machine: {machine_line()}; `python benchmarks/study_los_mc_qp_solver.py "
        + " ".join(str(folder) for folder in args.stores)
        + "` after the sweeps (module docstring).",
        "",
        "| " + " | ".join(header) + " |",
        "| --- | " + " | ".join("---:" for _ in header[1:]) + " |",
    ]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in table]
    lines += ["", *status_lines(flown)]
    if len(flown) >= 2:
        (name_a, _, rows_a), (name_b, _, rows_b) = flown[:2]
        by_start_b = {_start(row): row for row in rows_b}
        pairs = [(row, by_start_b[_start(row)]) for row in rows_a if _start(row) in by_start_b]
        duration_a, duration_b = mc.campaign_duration_s(rows_a), mc.campaign_duration_s(rows_b)
        differ = []
        for row_a, row_b in pairs:
            feasible_a, why_a = mc.classify_run(row_a, duration_a)
            feasible_b, why_b = mc.classify_run(row_b, duration_b)
            if feasible_a != feasible_b:
                differ.append((row_a, feasible_a, why_a, feasible_b, why_b))
        lines += [
            "",
            (
                f"On the {len(pairs)} starts both flew (matched by case and start): the outcome "
                f"is the same on {len(pairs) - len(differ)}, different on {len(differ)}."
            ),
        ]
        if differ:
            lines += [
                "",
                f"| case | start p_LC_L [m] | {name_a} | {name_b} |",
                "| --- | --- | --- | --- |",
            ]
            for row, feasible_a, why_a, feasible_b, why_b in differ:
                start = row["overrides"].get("chaser.p_LC_L")
                lines.append(
                    f"| {row['case_name']} | {start} | {'feasible' if feasible_a else 'not'}: "
                    f"{why_a} | {'feasible' if feasible_b else 'not'}: {why_b} |"
                )
    write_results(RESULTS, with_notes(RESULTS, lines, NOTES))


if __name__ == "__main__":
    main()
