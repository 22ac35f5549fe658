"""The shoot-out (issue 22) in one command: the campaign flown, its report, the committed table.

    python benchmarks/shootout.py [--out runs/shootout] [--workers 2] [--reuse OLD] [--fresh]
                                  [--report-only]

Runs `rpod sweep shootout --out OUT` (which resumes: finished runs are not flown again; with
`--reuse OLD`, the runs an earlier store finished under the same ids are recorded, not flown:
a campaign that changes one case flies only that case, and the table says how many; with
`--report-only`, nothing is flown and the pending runs are reported as pending), then
`rpod report OUT`, and writes benchmarks/results/shootout.md: the report's comparison of the
methods (rpod.scenarios.comparison) with the commit, the machine and the campaign's wall time,
and its three figures into benchmarks/results/shootout/.

The store itself is committed, xz-compressed (benchmarks/results/shootout/results.sqlite.xz,
~1.5 MB): the whole campaign takes longer than one working session on this 2-core machine, so
each invocation starts from it (its finished runs are recorded into OUT, `rpod sweep --reuse`,
not flown again) and writes OUT's store back into it when it ends. `--fresh` neither reuses
nor rewrites it: every run is flown anew into OUT (resumable like any sweep), and the table
says how many of the runs flown again give the numbers the committed store holds, run by run
(rpod.scenarios.reproducibility: the second run the issue asks for). `--report-only` flies
nothing (with `--reuse OLD`, OLD's finished runs are first recorded into OUT). The existing
file's sections written by hand (every `## ` section: the flights' provenance, what each method is best and worst at,
written from the table) are kept as they are below the regenerated part.
"""

from __future__ import annotations

import argparse
import contextlib
import lzma
import pathlib
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time

from machine import machine_line  # benchmarks/machine.py, beside this script

from rpod.scenarios.report import read_results, write_report
from rpod.scenarios.reproducibility import compare_runs
from rpod.scenarios.store import STORE_NAME, ResultStore, same_base

RESULTS = pathlib.Path(__file__).resolve().parent / "results"
TABLE = RESULTS / "shootout.md"
FIGURES = RESULTS / "shootout"
STORE_ARCHIVE = FIGURES / "results.sqlite.xz"  # the committed store (module docstring)
COMMAND = "python benchmarks/shootout.py"
ANALYSIS_START = "\n## "  # the first section written by hand (the table has none)
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


def _last_commit_of(path: pathlib.Path) -> str:
    result = subprocess.run(
        ["git", "-C", str(path.parent), "log", "-1", "--format=%h", "--", path.name],
        capture_output=True,
        text=True,
        check=False,
    )
    return result.stdout.strip() or "uncommitted"


def _reproduction_lines(
    rows: list[dict], committed: list[dict] | None, by_start: bool
) -> list[str]:
    """Whether the runs flown again here give the numbers of the committed store's (by_start:
    the two share their base, so a start sampled on another CPU pairs: store.counterparts)."""
    commit = _last_commit_of(STORE_ARCHIVE)
    if committed is None or commit == "uncommitted":
        return []  # no committed flight to compare with
    comparison = compare_runs(rows, committed, by_start)
    where = f"the committed store (commit {commit})"
    if comparison.compared == 0:
        return [
            (
                f"Second run: no run here was flown again since {where} "
                "(`--fresh` flies every run anew and compares them)."
            )
        ]
    lines = [
        f"Second run: {comparison.compared} runs flown again and compared with {where}: "
        f"{comparison.same} give the same numbers in every reproducible cell (everything in "
        "the run's summary but compute and wall times, rpod.scenarios.reproducibility; floats "
        "compared exactly)"
        + (f"; {comparison.only_here} finished here only" if comparison.only_here else "")
        + (f"; {comparison.only_there} there only" if comparison.only_there else "")
        + "."
    ]
    for run_id, cells in list(comparison.differing.items())[:10]:
        lines.append(f"- differs: run {run_id} in {', '.join(cells[:6])}")
    if len(comparison.differing) > 10:
        lines.append(f"- ... and {len(comparison.differing) - 10} more runs differ")
    return lines


def _unpack_committed(out: pathlib.Path) -> pathlib.Path:
    """The committed store, unpacked into a folder beside OUT (OUT + `_committed`)."""
    folder = out.parent / f"{out.name}_committed"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / STORE_NAME).write_bytes(lzma.decompress(STORE_ARCHIVE.read_bytes()))
    return folder


def _pack_store(out: pathlib.Path) -> None:
    """OUT's store (a consistent copy through SQLite's backup, vacuumed) into STORE_ARCHIVE."""
    with tempfile.TemporaryDirectory() as tmp:
        copy = pathlib.Path(tmp) / STORE_NAME
        source = sqlite3.connect(f"file:{out / STORE_NAME}?mode=ro", uri=True)
        with contextlib.closing(source), contextlib.closing(sqlite3.connect(copy)) as target:
            source.backup(target)
            target.execute("VACUUM")
        STORE_ARCHIVE.write_bytes(lzma.compress(copy.read_bytes(), preset=9))


def _record_reused(out: pathlib.Path, reuse: pathlib.Path) -> int:
    """OLD's finished runs recorded into OUT's store without flying (`--report-only --reuse`)."""
    with ResultStore(out / STORE_NAME) as store, ResultStore.open_existing(reuse) as other:
        return store.reuse(other, str(reuse))


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
        "--fresh",
        action="store_true",
        help="fly every run anew (the committed store is not reused): a second run",
    )
    parser.add_argument(
        "--report-only", action="store_true", help="fly nothing: the table of the stored runs"
    )
    args = parser.parse_args()

    start = time.perf_counter()
    out = pathlib.Path(args.out)
    reuse = pathlib.Path(args.reuse) if args.reuse else None
    committed_folder = _unpack_committed(out) if STORE_ARCHIVE.exists() else None
    if reuse is None and not args.fresh and committed_folder is not None:
        reuse = committed_folder
        if args.report_only and not (out / STORE_NAME).exists():
            out.mkdir(parents=True, exist_ok=True)
            shutil.copy(reuse / STORE_NAME, out / STORE_NAME)
    if args.report_only:
        if reuse is not None and (out / STORE_NAME).exists():
            print(f"shootout: {_record_reused(out, reuse)} runs recorded from {reuse}")
    else:
        sweep = ["rpod", "sweep", args.campaign, "--out", args.out, "--workers", str(args.workers)]
        if reuse is not None:
            sweep += ["--reuse", str(reuse)]
        if subprocess.run(sweep, check=False).returncode != 0:
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
    committed, by_start = None, False
    if committed_folder is not None:
        with (
            ResultStore.open_existing(committed_folder) as store,
            ResultStore.open_existing(out) as flown,
        ):
            committed = store.rows()
            by_start = same_base(flown.meta(), store.meta())
    reproduction = _reproduction_lines(rows, committed, by_start)
    if not args.fresh:  # a second flight is compared with the committed store, not written over it
        _pack_store(out)
    figures = []
    for plot in plots:
        if plot.name in ("success_vs_tumble.png", "success_vs_range.png", "delta_v_vs_range.png"):
            shutil.copy(plot, FIGURES / plot.name)
            figures.append(plot.name)
    analysis = ""
    if TABLE.exists() and ANALYSIS_START in TABLE.read_text():
        old = TABLE.read_text()
        analysis = old[old.index(ANALYSIS_START) + 1 :].rstrip() + "\n"

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
        *reproduction,
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
