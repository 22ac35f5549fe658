"""Resident memory over many `simulate()` calls in one process (issue 23: at most 50 MB per 1,000).

    python benchmarks/bench_memory.py [--runs 1000] [--reference-runs 100]

For each scenario, one process (this one) simulates it `--runs` times (two warm-up runs first:
imports, caches, the first plan), reading its resident set size (/proc/self/statm) after a
garbage collection every tenth of the way; then, as the reference in the same process, the same
scenario `--reference-runs` times with `release_diagram` switched off in simulate (what
pydrake 1.51 does without rpod.systems.lifetime's release; the weak callbacks stay on). Writes
benchmarks/results/memory.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import os
import pathlib
import time

from machine import machine_line, write_results

import rpod.diagrams.simulate as simulate_module
from rpod.scenarios.loader import load_scenario

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "memory.md"
GOAL_MB_PER_1000 = 50.0
# (scenario, duration [s]): short runs, so that building a diagram (what leaked) dominates.
CASES = (("hold_point", 20.0), ("soft_capture", 20.0), ("los_corridor_thrusters", 20.0))


def resident_mb() -> float:
    gc.collect()
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def grow(scenario, runs: int, checkpoints: int = 10) -> list[tuple[int, float]]:
    """(runs done, resident MB) at each checkpoint, after two warm-up runs."""
    for _ in range(2):
        simulate_module.simulate(scenario)
    points = [(0, resident_mb())]
    for i in range(1, runs + 1):
        simulate_module.simulate(scenario)
        if i % max(1, runs // checkpoints) == 0 or i == runs:
            points.append((i, resident_mb()))
    return points


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument("--reference-runs", type=int, default=100)
    args = parser.parse_args()
    start = time.perf_counter()
    rows = []
    for name, duration in CASES:
        _, base = load_scenario(name)
        scenario = dataclasses.replace(base, duration_s=duration)
        points = grow(scenario, args.runs)
        released = simulate_module.release_diagram
        simulate_module.release_diagram = lambda *roots: 0  # the reference: no release
        try:
            reference = grow(scenario, args.reference_runs)
        finally:
            simulate_module.release_diagram = released
        growth = points[-1][1] - points[0][1]
        per_run_kb = growth * 1024 / args.runs
        ref_kb = (reference[-1][1] - reference[0][1]) * 1024 / args.reference_runs
        halfway = next(mb for i, mb in points if i >= args.runs // 2)
        rows.append(
            f"| {name} | {duration:g} | {args.runs} | {points[0][1]:.1f} | {halfway:.1f} | "
            f"{points[-1][1]:.1f} | {growth:.1f} | {per_run_kb:.1f} | "
            f"{per_run_kb * 1000 / 1024:.1f} | {ref_kb:.0f} | "
            f"{'met' if per_run_kb * 1000 / 1024 <= GOAL_MB_PER_1000 else 'NOT met'} |"
        )
        print(rows[-1], flush=True)
    lines = [
        "# Resident memory over repeated simulate() calls (issue 23)",
        "",
        f"Machine: {machine_line()}.",
        (
            f"Command: `python benchmarks/bench_memory.py --runs {args.runs} --reference-runs "
            f"{args.reference_runs}`; {(time.perf_counter() - start) / 60:.0f} min in all."
        ),
        "",
        (
            "One process per table, each scenario simulated repeatedly after two warm-up runs; "
            "resident set size after `gc.collect()`. Reference: the same scenario in the same process "
            "with `release_diagram` switched off (pydrake 1.51 keeps such a diagram alive; "
            "rpod.systems.lifetime says why); the reference's leak is why each scenario starts higher "
            "than the last. Goal: at most "
            f"{GOAL_MB_PER_1000:g} MB per 1,000 runs."
        ),
        "",
        (
            "| scenario | duration s | runs | RSS after warm-up MB | RSS halfway MB | RSS at end MB "
            "| growth MB | per run kB | per 1,000 runs MB | reference per run kB (no release) | goal |"
        ),
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
        *rows,
    ]
    write_results(RESULTS, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
