"""Where `rpod run hold_point`'s time goes, against the benchmark's best-of real-time factor
(issue 23: "rpod run hold_point --no-record gives 60-73x while the benchmark's best-of-3 gives
127x; say where the difference goes").

    python benchmarks/bench_run_hold_point.py [--repeats 5]

In one run, interleaved repeat by repeat so that load hits each alike:
- `rpod run hold_point --no-record` in a subprocess (what a user types), and the same with
  `--no-plots`: the command's wall time, and from its summary.json the wall time of
  `simulate` (its real-time factor is the one `rpod run` prints) and of the diagram's build;
- in this process, `simulate(hold_point)` as bench_hold_point.py times it (no recording; the
  run's logging as `rpod run` has it), so the two real-time factors compare like for like;
- bench_hold_point.py's plain-numpy replay of the same integration (its section 2), the
  machine's floor for it: issue 23's goal is the diagram within 2.5x of it.
The rest of a command's wall time is the interpreter's start and imports, loading the
scenario, and writing log.npz, summary.json and the plots. Reported: medians and bests.
Writes benchmarks/results/run_hold_point.md.
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np
from machine import machine_line, write_results  # benchmarks/machine.py, beside this script

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "run_hold_point.md"
COMMAND = "python benchmarks/bench_run_hold_point.py"


def command_run(folder: pathlib.Path, plots: bool) -> dict:
    """One `rpod run hold_point --no-record` [--no-plots]: its wall time and its summary."""
    command = ["rpod", "run", "hold_point", "--no-record", "--out", str(folder)]
    if not plots:
        command.append("--no-plots")
    start = time.perf_counter()
    process = subprocess.run(command, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    if process.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited {process.returncode}: {process.stderr}")
    summary = json.loads((folder / "summary.json").read_text())
    return {
        "wall": wall,
        "simulate": summary["wall_time_s"],
        "build": summary["build_time_s"],
        "sim_s": summary["sim_time_s"],
    }


def in_process_run() -> dict:
    """simulate(hold_point) here, as bench_hold_point.py times it."""
    from rpod.diagrams.simulate import simulate
    from rpod.scenarios.loader import load_scenario

    _, scenario = load_scenario("hold_point")
    start = time.perf_counter()
    result = simulate(scenario)
    wall = time.perf_counter() - start
    return {
        "wall": wall,
        "simulate": result.summary["wall_time_s"],
        "build": result.summary["build_time_s"],
        "sim_s": result.summary["sim_time_s"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    load_start = os.getloadavg()
    began = time.perf_counter()
    in_process_run()  # warm-up: imports and the first build
    runs = {"rpod run --no-record": [], "rpod run --no-record --no-plots": [], "in process": []}
    with tempfile.TemporaryDirectory() as folder:
        for repeat in range(args.repeats):
            order = list(runs)
            order = order[repeat % 3 :] + order[: repeat % 3]
            for name in order:
                out = pathlib.Path(folder) / f"{repeat}-{len(runs[name])}-{name[-5:]}"
                if name == "in process":
                    runs[name].append(in_process_run())
                else:
                    runs[name].append(command_run(out, plots="plots" not in name))
            print(f"  repeat {repeat + 1}/{args.repeats}", file=sys.stderr, flush=True)
    from bench_hold_point import plain_reference  # benchmarks/, beside this script

    from rpod.scenarios.loader import load_scenario

    replay = plain_reference(load_scenario("hold_point")[1], args.repeats)
    load_end = os.getloadavg()

    lines = ["# `rpod run hold_point`: where the time goes (issue 23)", ""]
    lines.append(f"Machine: {machine_line()}.")
    lines.append(
        f"Command: `{COMMAND} --repeats {args.repeats}` "
        f"({time.perf_counter() - began:.0f} s); 1/5/15-minute load average "
        f"{load_start[0]:.2f}/{load_start[1]:.2f}/{load_start[2]:.2f} at the start, "
        f"{load_end[0]:.2f}/{load_end[1]:.2f}/{load_end[2]:.2f} at the end, on "
        f"{os.cpu_count()} cores. The three kinds of run interleaved, {args.repeats} of each."
    )
    lines += [
        "",
        (
            "| run | RTF of `simulate`, median (best) | `simulate` (s) median | build (s) | "
            "whole command (s) median | the command's rest: start, imports, load, outputs (s) "
            "| RTF over the whole command |"
        ),
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name, data in runs.items():
        sim = np.array([d["simulate"] for d in data])
        wall = np.array([d["wall"] for d in data])
        build = np.array([d["build"] for d in data])
        sim_s = data[0]["sim_s"]
        rest = wall - sim - build if name != "in process" else None
        lines.append(
            f"| {name} | {sim_s / np.median(sim):.0f} ({sim_s / sim.min():.0f}) | "
            f"{np.median(sim):.2f} | {np.median(build):.3f} | "
            + (
                f"{np.median(wall):.2f} | {np.median(rest):.2f} | {sim_s / np.median(wall):.0f} |"
                if rest is not None
                else "-- | -- | -- |"
            )
        )
    in_process = min(d["simulate"] for d in runs["in process"])
    replay_rtf = replay["sim_s"] / replay["wall_s"]
    lines += [
        "",
        (
            "The plain-numpy replay of the same integration (bench_hold_point.py, section 2; "
            f"best of {args.repeats}): {replay['wall_s']:.2f} s, {replay_rtf:.0f}x real time; "
            f"the diagram's `simulate` (best, in process) costs {in_process / replay['wall_s']:.1f}x "
            "it (issue 23's goal: at most 2.5x)."
        ),
    ]
    write_results(RESULTS, lines)


if __name__ == "__main__":
    main()
