"""The shoot-out (issue 22) in one command: the campaign flown, its report, the committed table.

    python benchmarks/shootout.py [--out runs/shootout] [--workers 2] [--reuse OLD] [--report-only]

Runs `rpod sweep shootout --out OUT` (which resumes: finished runs are not flown again; with
`--reuse OLD`, the runs an earlier store finished under the same ids are recorded, not flown:
a campaign that changes one case flies only that case, and the table says how many; with
`--report-only`, nothing is flown and the pending runs are reported as pending), then
`rpod report OUT`, and writes benchmarks/results/shootout.md: the report's comparison of the
methods (rpod.scenarios.comparison) with the commit, the machine and the campaign's wall time,
and its three figures into benchmarks/results/shootout/. A section of the existing file headed
ANALYSIS_HEADING (the paragraph on what each method is best and worst at, written from the
table) is kept as it is below the regenerated part.
"""

from __future__ import annotations

import argparse
import pathlib
import shutil
import subprocess
import sys
import time

from machine import machine_line  # benchmarks/machine.py, beside this script

from rpod.scenarios.report import read_results, write_report

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
TABLE = RESULTS / "shootout.md"
FIGURES = RESULTS / "shootout"
COMMAND = "python benchmarks/shootout.py"
ANALYSIS_HEADING = "## What each method is best and worst at"
SECTION_START, SECTION_END = "Methods compared on the same", "Metrics over the ok runs"


def _commit() -> str:
    root = pathlib.Path(__file__).resolve().parent.parent
    result = subprocess.run(
        ["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
        capture_output=True,
        text=True,
        check=False,
    )
    return result.stdout.strip() or "unknown"


def _comparison(text: str) -> str:
    start = text.index(SECTION_START)
    end = text.find(SECTION_END, start)
    return text[start : end if end >= 0 else len(text)].rstrip()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="runs/shootout", help="the campaign's output folder")
    parser.add_argument("--workers", type=int, default=2, help="local worker processes")
    parser.add_argument(
        "--campaign", default="shootout", help="the campaign (default: the bundled shootout)"
    )
    parser.add_argument(
        "--reuse", help="an earlier results folder whose finished runs are recorded (rpod sweep)"
    )
    parser.add_argument(
        "--report-only", action="store_true", help="fly nothing: the table of the stored runs"
    )
    args = parser.parse_args()

    start = time.perf_counter()
    sweep = ["rpod", "sweep", args.campaign, "--out", args.out, "--workers", str(args.workers)]
    if args.reuse:
        sweep += ["--reuse", args.reuse]
    if not args.report_only and subprocess.run(sweep, check=False).returncode != 0:
        print("shootout: the sweep did not finish; run the same command again to resume")
        return 1
    elapsed = time.perf_counter() - start
    text, plots = write_report(args.out, overwrite=True)
    _, rows = read_results(args.out)
    head = "\n\n".join(text.split("\n\n")[0:3])  # the campaign, its success, its groups
    run_wall = sum(r["wall_time_s"] or 0.0 for r in rows)
    reused = sum(1 for r in rows if (r["worker"] or "").startswith("reused from"))
    pending = sum(1 for r in rows if r["status"] == "pending")
    reused_line = (
        f"{reused} of the runs were recorded from an earlier store (`rpod sweep --reuse`): the "
        "cases whose scenarios, and so run ids, did not change; they were flown by the code "
        "that stored them."
    )

    FIGURES.mkdir(parents=True, exist_ok=True)
    figures = []
    for plot in plots:
        if plot.name in ("success_vs_tumble.png", "success_vs_range.png", "delta_v_vs_range.png"):
            shutil.copy(plot, FIGURES / plot.name)
            figures.append(plot.name)
    analysis = ""
    if TABLE.exists() and ANALYSIS_HEADING in TABLE.read_text():
        old = TABLE.read_text()
        analysis = old[old.index(ANALYSIS_HEADING) :].rstrip() + "\n"

    lines = [
        "# The shoot-out: rpod's 3-D methods on one capture task (issue 22)",
        "",
        (
            f"Command: `{COMMAND}` (`rpod sweep {args.campaign}`, then `rpod report`), commit "
            f"{_commit()}, {time.strftime('%Y-%m-%d')}."
        ),
        f"Machine: {machine_line()}.",
        (
            f"Campaign: {len(rows)} runs, {run_wall / 3600:.2f} h of run wall time on "
            f"{args.workers} workers; this command took {elapsed / 60:.0f} min (runs already "
            "stored are not flown again)."
        ),
        *([reused_line] if reused else []),
        *(
            [f"{pending} runs are still pending (not flown yet): the table counts the rest."]
            if pending
            else []
        ),
        "",
        "```",
        head,
        "",
        _comparison(text),
        "```",
        "",
        *[f"![{name}](shootout/{name})" for name in figures],
        "",
    ]
    TABLE.write_text("\n".join(lines) + ("\n" + analysis if analysis else ""))
    print(f"wrote {TABLE} and {len(figures)} figures into {FIGURES}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
