"""What navigation costs: the filter per update, the navigation per tick, and its share of a run.

    python benchmarks/bench_navigation.py [--repeat N]

Prints the tables and writes them to benchmarks/results/navigation_cost.md. Every figure is
measured in this run:

1. The filter's parts on a converged state (rpod.models.relative_navigation): one prediction
   over the 0.5 s between two fixes (covariance and nominal, one step at the default
   max_step_s), the nominal alone carried over it, one Joseph update with its multiplicative
   reset; median of many calls.
2. The navigation's work at one of its events (rpod.systems.navigation.NavigationComputer.tick)
   with and without a pose fix taken (and the filter updated by it), and the estimate read
   between events (`sensed_at`).
3. Its share of a run's wall time: each scenario flown truth-fed and on `navigation: !Ekf`,
   the two alternating, best of N each (so load on a shared machine hits both alike: on this
   2-core VM one run's wall time varies by 10-15 %, hence 5 by default); the share is
   (Ekf - truth) / truth, the navigation's cost against the run without it. The issue's goal:
   at most 20 % of hold_point's.
"""

from __future__ import annotations

import argparse
import dataclasses
import pathlib
import statistics
import sys
import time

import numpy as np
from machine import machine_line  # benchmarks/machine.py, beside this script

from rpod.diagrams.simulate import simulate
from rpod.models import relative_navigation as rn
from rpod.scenarios.loader import load_scenario
from rpod.systems.navigation_config import Ekf

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "navigation_cost.md"
COMMAND = "python benchmarks/bench_navigation.py"
GOAL_SHARE = 0.20
SCENARIOS = ("hold_point", "soft_capture", "los_corridor")


def _median_us(call, count: int) -> float:
    times = []
    for _ in range(count):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return 1e6 * statistics.median(times)


def filter_parts(count: int = 2000) -> list[tuple[str, float]]:
    """(part, median us) of the filter's mathematics on a converged 3-D tumble."""
    settings = rn.FilterSettings()
    state = rn.FilterState(
        t=0.0,
        p_LC_L=np.array([3.0, -20.0, 1.0]),
        v_LC_L=np.array([0.01, 0.0, 0.0]),
        q_IT=np.array([1.0, 0.0, 0.0, 0.0]),
        w_IT_T=np.radians([2.0, 1.0, 3.0]),
        inertia_parameters=np.array([0.3, -0.4]),
        P=np.diag([1e-4] * 3 + [1e-6] * 3 + [1e-4] * 3 + [1e-8] * 3 + [1e-4] * 2),
    )
    fix = rn.PoseMeasurement(0.5, state.p_LC_L + 0.01, state.q_IT, 0.2, np.radians(2.0))
    gate = rn.chi_square_quantile(settings.gate_probability, rn.MEASUREMENT_SIZE)
    n = 0.0011
    return [
        (
            "predict 0.5 s (covariance and nominal)",
            _median_us(
                lambda: rn.predict(
                    state, 0.5, n, settings.noise, (0, 0, 0), settings.max_step_s, 10.0
                ),
                count,
            ),
        ),
        (
            "carry the nominal 0.5 s",
            _median_us(
                lambda: rn.propagate_nominal(state, 0.5, n, (0, 0, 0), settings.max_step_s), count
            ),
        ),
        (
            "update by one pose fix (gate, Joseph form, reset)",
            _median_us(lambda: rn.update(state, fix, gate, 10.0), count),
        ),
    ]


def tick_parts() -> list[tuple[str, float]]:
    """(part, median us) of the navigation's tick and of the estimate's reads, timed inside a
    hold_point run on `!Ekf` (the computer's methods wrapped by a timer), the events split by
    whether a fix was taken and the filter updated by it."""
    from rpod.systems import navigation as navigation_module

    computer_type = navigation_module.NavigationComputer
    tick, sensed_at = computer_type.tick, computer_type.sensed_at
    with_fix, without, reads = [], [], []

    def timed_tick(self, previous, index, truth):
        start = time.perf_counter()
        after = tick(self, previous, index, truth)
        elapsed = time.perf_counter() - start
        (with_fix if after.counts[:2] != previous.counts[:2] else without).append(elapsed)
        return after

    def timed_read(self, memory, t, chaser_state_I, q_IC_true):
        start = time.perf_counter()
        out = sensed_at(self, memory, t, chaser_state_I, q_IC_true)
        reads.append(time.perf_counter() - start)
        return out

    _, scenario = load_scenario("hold_point")
    computer_type.tick, computer_type.sensed_at = timed_tick, timed_read
    try:
        simulate(dataclasses.replace(scenario, navigation=Ekf()))
    finally:
        computer_type.tick, computer_type.sensed_at = tick, sensed_at
    return [
        (f"event with a fix taken ({len(with_fix)})", _median_or_nan(with_fix)),
        (f"event without one ({len(without)})", _median_or_nan(without)),
        (
            f"estimate read by a controller or logger ({len(reads)} reads)",
            1e6 * statistics.median(reads),
        ),
    ]


def _median_or_nan(seconds: list[float]) -> float:
    return 1e6 * statistics.median(seconds) if seconds else float("nan")


def _events_per_second() -> float:
    """The navigation's events per simulated second at the defaults (one sensor cycle)."""
    from rpod.systems.navigation import NavigationComputer

    computer = NavigationComputer(Ekf(), 0, 0.0011, "two_body_j2", np.array([1.0, 0.0, 0.0]))
    cycle = computer.tick_at(1.0) - computer.tick_at(0.0)
    return sum(computer.is_event(k) for k in range(cycle)) / 1.0


def run_shares(repeat: int) -> list[tuple[str, float, float, float, dict]]:
    """(scenario, truth wall s, Ekf wall s, share, Ekf summary) per scenario, best of repeat."""
    rows = []
    for name in SCENARIOS:
        _, scenario = load_scenario(name)
        estimated = dataclasses.replace(scenario, navigation=Ekf())
        truth_walls, ekf_walls, summary = [], [], None
        for _ in range(repeat):
            truth_walls.append(simulate(scenario).summary["wall_time_s"])
            result = simulate(estimated).summary
            ekf_walls.append(result["wall_time_s"])
            summary = result
        truth_s, ekf_s = min(truth_walls), min(ekf_walls)
        rows.append((name, truth_s, ekf_s, (ekf_s - truth_s) / truth_s, summary))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    lines = [
        "# What navigation costs",
        "",
        f"Command: `{COMMAND} --repeat {args.repeat}` ({machine_line()}).",
    ]
    for heading, parts in (
        ("The filter's parts (converged 3-D tumble; median of 2,000 calls)", filter_parts()),
        ("The navigation's events (inside a hold_point run on `!Ekf`; medians)", tick_parts()),
    ):
        lines += ["", f"## {heading}", "", "| part | median [us] |", "|---|---|"]
        lines += [f"| {part} | {us:.0f} |" for part, us in parts]
    lines += [
        "",
        f"## Share of a run's wall time (best of {args.repeat}, truth-fed and `!Ekf` alternating)",
        "",
        "| scenario | truth-fed [s] | on `!Ekf` [s] | navigation's share | its events | goal |",
        "|---|---|---|---|---|---|",
    ]
    for name, truth_s, ekf_s, share, summary in run_shares(args.repeat):
        events = round(summary["sim_time_s"] * _events_per_second())
        goal = (
            ("met" if share <= GOAL_SHARE else "NOT met") + f" (at most {GOAL_SHARE:.0%})"
            if name == "hold_point"
            else "-"
        )
        lines.append(f"| {name} | {truth_s:.2f} | {ekf_s:.2f} | {share:.0%} | {events} | {goal} |")
    text = "\n".join(lines) + "\n"
    RESULTS.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
