"""Every bundled scenario run as the README's command runs it: the numbers of its scenario table.

    python benchmarks/bundled_runs.py [--no-record] [NAME ...]

Each run is `rpod run NAME --out <temporary folder>` in a subprocess (recording included unless
--no-record: `rpod run` records by default), plus the variants the README quotes
(`los_corridor_3d` on the paper's frozen model). From each run's summary.json the table takes
the one line `rpod run` printed (mission outcome first), delta-v, the least separation, contact,
and two real-time factors: simulated time over the wall time of `simulate` (the summary's
real_time_factor) and over the whole command (start-up, plots and recording included), the one
a user waits for. Writes benchmarks/results/bundled_runs.md.
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

from machine import machine_line, write_results  # benchmarks/machine.py, beside this script

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "bundled_runs.md"
VARIANTS = {  # README-quoted variants: name -> (base scenario, --set overrides)
    "los_corridor_3d (frozen model)": (
        "los_corridor_3d",
        ["controller.time_varying_model=false"],
    ),
}


def bundled_names() -> list[str]:
    """The bundled scenarios, as `rpod list` knows them."""
    from rpod.scenarios.loader import bundled_scenarios

    return sorted(bundled_scenarios())


def run_one(scenario: str, overrides: list[str], record: bool, folder: pathlib.Path) -> dict:
    """Runs `rpod run` once; returns its summary, line, exit status and command wall time."""
    command = ["rpod", "run", scenario, "--out", str(folder)]
    command += [arg for value in overrides for arg in ("--set", value)]
    if not record:
        command.append("--no-record")
    started = time.perf_counter()
    process = subprocess.run(command, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - started
    summary_file = folder / "summary.json"
    summary = json.loads(summary_file.read_text()) if summary_file.exists() else {}
    line = (process.stdout.strip().splitlines() or ["(no line)"])[-1]
    return {
        "command": " ".join(command[:3] + command[5:]),
        "exit": process.returncode,
        "line": line,
        "summary": summary,
        "wall_s": wall,
        "stderr": process.stderr.strip().splitlines()[-1:] if process.returncode else [],
    }


def _number(value, digits=3) -> str:
    return "--" if value is None else f"{value:.{digits}g}"


def table_row(name: str, result: dict) -> str:
    s = result["summary"]
    mission = s.get("mission") or {}
    verdict = {True: "success", False: "**failed**", None: "no mission"}[mission.get("success")]
    contact = (s.get("contact") or {}).get("occurred")
    sim = s.get("sim_time_s")
    rtf_command = sim / result["wall_s"] if sim else None
    cells = [
        name,
        verdict,
        f"`{result['command']}`",
        _number(sim, 4),
        _number(s.get("delta_v_m_s"), 4),
        _number(s.get("min_separation_m")),
        "**yes**" if contact else "no",
        _number(s.get("real_time_factor")),
        _number(rtf_command),
        str(result["exit"]),
        result["line"].split(" -> ")[0].replace("|", "/"),
    ]
    return "| " + " | ".join(cells) + " |"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="scenarios (default: every bundled one)")
    parser.add_argument("--no-record", action="store_true", help="runs without recording.html")
    args = parser.parse_args(argv)
    names = args.names or bundled_names()
    runs = [(name, name, []) for name in names]
    runs += [(label, base, sets) for label, (base, sets) in VARIANTS.items() if base in names]
    load_start = os.getloadavg()
    started = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory(prefix="rpod-bundled-") as folder:
        for i, (label, scenario, sets) in enumerate(runs):
            print(f"  {label} ...", file=sys.stderr, flush=True)
            result = run_one(scenario, sets, not args.no_record, pathlib.Path(folder) / str(i))
            rows.append(table_row(label, result))
    load_end = os.getloadavg()
    record = "without recording (--no-record)" if args.no_record else "with recording.html"
    lines = [
        "# The bundled scenarios, run as `rpod run` runs them",
        "",
        f"Machine: {machine_line()}; `python benchmarks/bundled_runs.py"
        + (" --no-record" if args.no_record else "")
        + f"`; {time.perf_counter() - started:.0f} s in all, {record}. 1-minute load average "
        f"{load_start[0]:.2f} at the start, {load_end[0]:.2f} at the end (2 cores shared with "
        "other work: wall times carry that noise).",
        "",
        (
            "RTF (simulate): simulated time over the wall time of `simulate`. RTF (command): over "
            "the whole `rpod run` (start-up, plots, recording): what a user waits for. Exit: 0 "
            "success or no mission, 3 mission failed. The line is the one `rpod run` printed."
        ),
        "",
        (
            "| scenario | mission | command | simulated (s) | delta-v (m/s) | min separation (m) "
            "| contact | RTF (simulate) | RTF (command) | exit | line |"
        ),
        "| --- | --- | --- | ---: | ---: | ---: | --- | ---: | ---: | ---: | --- |",
        *rows,
    ]
    write_results(RESULTS, lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
