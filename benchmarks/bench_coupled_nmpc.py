"""Paper 001's NMPC in closed loop: time per solve with each solver, and real-time factors.

    python benchmarks/bench_coupled_nmpc.py [--ipopt-duration S]

Flies `asteroid_grasp` (no recording) on rpod's truth with each solver of
rpod.planners.coupled_nmpc: the Gauss-Newton SQP to convergence ("sqp", the bundled scenario),
one real-time iteration per step ("rti"), and the paper's IPOPT and SNOPT through Drake's
MathematicalProgram (max_iterations 100 each; they are flown for --ipopt-duration seconds only,
600 by default, as each failed solve costs ~10 s). Every call of `CoupledNmpc.solve` is timed
from outside (guess, target reference, solve), its status counted; "unreported" counts control
steps whose status the log does not hold (the acceptance's "zero unreported failures").

Goals (issue 12): IPOPT median under 100 ms and p99 under 0.5 s at N = 8; RTI median under
10 ms; zero unreported failures. Writes benchmarks/results/coupled_nmpc.md.
"""

import argparse
import collections
import dataclasses
import os
import pathlib
import sys
import time

import numpy as np
from machine import machine_line, write_results  # benchmarks/machine.py, beside this script

from rpod.diagrams.simulate import simulate
from rpod.planners.coupled_nmpc import CoupledNmpc
from rpod.scenarios.loader import load_scenario

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "coupled_nmpc.md"
COMMAND = "python benchmarks/bench_coupled_nmpc.py"
SCENARIO = "asteroid_grasp"


def run(scenario, solver: str, max_iterations: int, duration_s: float) -> dict:
    """One closed loop with `solver`: the solve() wall times and statuses, and the summary."""
    nmpc = dataclasses.replace(
        scenario.controller.nmpc, solver=solver, max_iterations=max_iterations
    )
    case = dataclasses.replace(
        scenario,
        controller=dataclasses.replace(scenario.controller, nmpc=nmpc),
        duration_s=duration_s,
    )
    times, statuses = [], collections.Counter()
    original = CoupledNmpc.solve

    def timed(self, *args, **kwargs):
        start = time.perf_counter()
        result = original(self, *args, **kwargs)
        times.append(time.perf_counter() - start)
        statuses[result.status.value] += 1
        return result

    CoupledNmpc.solve = timed
    try:
        summary = simulate(case).summary
    finally:
        CoupledNmpc.solve = original
    return {"times": np.array(times), "statuses": statuses, "summary": summary}


def row(solver: str, max_iterations: int, m: dict) -> str:
    t, s = 1e3 * m["times"], m["summary"]
    warm = t[1:] if len(t) > 1 else t  # the first solve is a cold start
    steps = len(t)
    logged = sum(s["nmpc_solves_by_status"].values())
    statuses = ", ".join(f"{k} {v}" for k, v in sorted(m["statuses"].items()))
    return (
        f"| {solver} | {max_iterations} | {s['sim_time_s']:.0f} | {steps} | {t[0]:.0f} | "
        f"{np.median(warm):.1f} | {np.percentile(warm, 95):.1f} | {np.percentile(warm, 99):.1f} | "
        f"{warm.max():.1f} | {statuses} | {s['nmpc_not_usable']} | {steps - logged} | "
        f"{s['real_time_factor']:.0f}x | {s['mission']['outcome']} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ipopt-duration", type=float, default=600.0)
    args = parser.parse_args()
    load = os.getloadavg()
    _, scenario = load_scenario(SCENARIO)
    cases = [
        ("sqp", scenario.controller.nmpc.max_iterations, scenario.duration_s),
        ("rti", scenario.controller.nmpc.max_iterations, scenario.duration_s),
        ("ipopt", 100, args.ipopt_duration),
        ("snopt", 100, args.ipopt_duration),
    ]
    rows, medians = [], {}
    for solver, max_iterations, duration in cases:
        m = run(scenario, solver, max_iterations, duration)
        rows.append(row(solver, max_iterations, m))
        medians[solver] = (np.median(m["times"][1:]), np.percentile(m["times"][1:], 99))
        print(rows[-1], file=sys.stderr, flush=True)
    ipopt_median, ipopt_p99 = medians["ipopt"]
    rti_median = medians["rti"][0]
    lines = [
        "# Paper 001's NMPC in closed loop: time per solve and real-time factors",
        "",
        (
            f"Machine: {machine_line()}; `{COMMAND} --ipopt-duration {args.ipopt_duration:g}`; "
            f"1-minute load average {load[0]:.2f} at the start. Scenario `{SCENARIO}` (N = 8, "
            "T = 480 s, solved every 60 s), no recording."
        ),
        "",
        (
            "Times are of each `CoupledNmpc.solve` call (guess, target reference and solver), "
            "timed from outside; the statistics leave out the first, cold solve (its own "
            "column). unreported: control steps whose status the log does not hold. RTF: "
            "simulated time over the wall time of `simulate`."
        ),
        "",
        (
            "| solver | max iterations | simulated (s) | solves | cold solve (ms) | median (ms) | "
            "p95 (ms) | p99 (ms) | max (ms) | statuses | not flown | unreported | RTF | "
            "outcome |"
        ),
        (
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: "
            "| --- |"
        ),
        *rows,
        "",
        "Goals (issue 12):",
        "",
        (
            f"- IPOPT median under 100 ms and p99 under 0.5 s: median {1e3 * ipopt_median:.0f} ms,"
            f" p99 {1e3 * ipopt_p99:.0f} ms: "
            f"{'met' if ipopt_median < 0.1 and ipopt_p99 < 0.5 else 'NOT met'}."
        ),
        (
            f"- RTI median under 10 ms: {1e3 * rti_median:.1f} ms: "
            f"{'met' if rti_median < 0.01 else 'NOT met'}."
        ),
    ]
    write_results(RESULTS, lines)


if __name__ == "__main__":
    main()
