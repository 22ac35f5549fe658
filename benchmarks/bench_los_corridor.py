"""Closed-loop speed of paper 004's guidance on rpod's truth: real-time factors and where the
wall time goes.

    python benchmarks/bench_los_corridor.py [--repeat N]

For each LOS-corridor scenario (no recording): the best of N real-time factors of `simulate`
(simulated time / wall time of the simulation, as summary.json's real_time_factor), the
mission outcome, and the wall time split into the MPC's solves (its own per-step timer), the
rest of the guidance step (the exact Jacobian, the regimes) and everything else (truth,
actuation, logging, Drake). The reference is the same scenario with the guidance's filter off
(`filter: false`, the regime's command alone: same truth, same logging, no QP, no Jacobian),
measured in the same run, alternating with the full one.

Goals (issue 10): los_corridor at least 200x real time; the paper's own code reaches about 41x
on its best single run (paper 004, Sec. 10.7 and its public code, as the issue reports it).
Writes benchmarks/results/los_corridor.md.
"""

import argparse
import dataclasses
import os
import pathlib
import sys

from machine import (
    best_of_alternating,
    machine_line,
    timed,
    write_results,
)  # benchmarks/machine.py, beside this script

from rpod.diagrams.simulate import simulate
from rpod.planners.los_corridor_mpc import LosCorridorMpc
from rpod.scenarios.loader import load_scenario
from rpod.systems import los_guidance

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "los_corridor.md"
COMMAND = "python benchmarks/bench_los_corridor.py"
SCENARIOS = ("los_corridor", "los_corridor_thrusters", "los_corridor_3d", "los_corridor_far")
GOAL = {"los_corridor": 200.0}


def run(scenario) -> dict:
    """One simulate(): its summary, the guidance step's wall time and the MPC solves'."""
    restore_guidance, guidance = timed(los_guidance.LosGuidance, "_update")
    restore_mpc, mpc = timed(LosCorridorMpc, "solve")
    try:
        summary = simulate(scenario).summary
    finally:
        restore_mpc()
        restore_guidance()
    return {"summary": summary, "guidance_s": guidance[0], "mpc_s": mpc[0]}


def goal_cell(name: str, factor: float) -> str:
    """'>= 200x: met' (or NOT met) for a scenario with a goal, else '-'."""
    goal = GOAL.get(name)
    if goal is None:
        return "-"
    return f">= {goal:.0f}x: {'met' if factor >= goal else 'NOT met'}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    load = os.getloadavg()
    rows = []
    for name in SCENARIOS:
        _, scenario = load_scenario(name)
        unfiltered = dataclasses.replace(
            scenario, controller=dataclasses.replace(scenario.controller, filter=False)
        )
        best, ref = best_of_alternating(run, scenario, unfiltered, args.repeat)
        s = best["summary"]
        wall = s["wall_time_s"]
        rows.append(
            f"| {name} | {s['sim_time_s']:.0f} | {s['real_time_factor']:.0f}x | "
            f"{goal_cell(name, s['real_time_factor'])} | "
            f"{ref['summary']['real_time_factor']:.0f}x | "
            f"{s['real_time_factor'] / ref['summary']['real_time_factor']:.2f} | "
            f"{100 * best['mpc_s'] / wall:.0f} % | "
            f"{100 * (best['guidance_s'] - best['mpc_s']) / wall:.0f} % | "
            f"{100 * (wall - best['guidance_s']) / wall:.0f} % | {s['mission']['outcome']} |"
        )
        print(rows[-1], file=sys.stderr, flush=True)
    lines = [
        "# Paper 004's guidance in closed loop: real-time factors",
        "",
        (
            f"Machine: {machine_line()}; `{COMMAND} --repeat {args.repeat}`; 1-minute load "
            f"average {load[0]:.2f} at the start. Best of {args.repeat}; no recording."
        ),
        "",
        (
            "Real-time factor: simulated time over the wall time of `simulate` (the diagram "
            "built, run and its log collected). Reference: the same scenario with `filter: "
            "false` (the regimes' command alone: no QP, no Jacobian), alternating with the full "
            "run. The wall time split: the MPC's solves (its own timer), the rest of the "
            "guidance's 1 Hz step (the exact Jacobian, the regimes), everything else (truth, "
            "actuation, logging, Drake). Paper 004's own code: about 41x on its best single run."
        ),
        "",
        (
            "| scenario | simulated (s) | real-time factor | goal | without the filter | "
            "ratio | MPC | rest of guidance | truth and the rest | outcome |"
        ),
        "| --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | --- |",
        *rows,
    ]
    write_results(RESULTS, lines)


if __name__ == "__main__":
    main()
