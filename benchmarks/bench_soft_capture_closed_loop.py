"""Real-time factor of the closed-loop soft capture, and where its wall time goes.

    python benchmarks/bench_soft_capture_closed_loop.py [--samples 6] [--repeat 2]

Prints two tables and writes them to benchmarks/results/soft_capture_closed_loop.md. Every
figure is measured in this run, and ratios are to a reference measured in the same run:

- Runs: the bundled ``soft_capture`` scenario (70 s) and the first ``--samples`` sampled starts
  of the bundled campaign ``soft_capture_250`` (120 s each), built as the campaign harness
  builds them (``apply_overrides(campaign.base, run.overrides)``), simulated in this process
  with ``rpod.diagrams.simulate.simulate`` (no recording, no plots).
- Reference: the bundled ``hold_point`` scenario with its ``duration_s`` set to the soft-capture
  run's. It has the same truth (two-body + J2 translation, torque-free tumble), the same thruster
  bank (12 RCS thrusters, allocator, PWM at 10 Hz with 10 slots) and integrator
  (runge_kutta3, 1e-6), and no planner. Each soft-capture run is paired with its own reference
  run, the two back to back; the order inside a pair alternates, and the order of the pairs is
  rotated from repeat to repeat, so that load on a shared machine hits both alike. Each pair is
  run ``--repeat`` times; figures are medians over the repeats, and ratios are medians of the
  per-repeat paired ratios.

Wall time of a run, here: the summary's ``build_time_s + wall_time_s``, i.e. diagram build,
``Simulator.Initialize`` and ``AdvanceTo`` (log collection and post-processing excluded). The
summary's own ``real_time_factor`` counts ``Initialize`` and ``AdvanceTo`` (the soft-capture
controller makes its initial plan in an initialization event, inside ``Initialize``); it
leaves out only the diagram build. It is listed beside ours for comparison.

Planning wall time: the sum of ``wall_time_s`` over the summary's ``plans`` records (one per
planner call: target prediction + the planner's horizon search, program builds included).
Non-planning wall time: run wall time less planning. "RTF excl. planning": simulated time over
non-planning wall time. Non-planning cost ratio: non-planning wall time per simulated second of
the soft capture over the reference's wall time per simulated second.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import os
import pathlib
import statistics
import sys
import time

from machine import machine_line  # benchmarks/machine.py, beside this script

from rpod.diagrams.simulate import simulate
from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs
from rpod.scenarios.loader import load_scenario

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "soft_capture_closed_loop.md"
CAMPAIGN = "soft_capture_250"
SHARED_LOAD = 1.5  # 1-minute load above this on the machine: other work shares its cores


@dataclasses.dataclass
class Measure:
    """One simulated run."""

    status: str
    sim_s: float
    wall_s: float  # build + Initialize + AdvanceTo
    advance_rtf: float  # the summary's real_time_factor (Initialize + AdvanceTo)
    steps: int
    plan_calls: int = 0
    plan_s: float = 0.0
    initial_plan_s: float = 0.0
    initial_N: int = 0
    capture: bool | None = None

    @property
    def rtf(self) -> float:
        return self.sim_s / self.wall_s

    @property
    def other_s(self) -> float:
        return self.wall_s - self.plan_s

    @property
    def rtf_other(self) -> float:
        return self.sim_s / self.other_s


def measure(scenario) -> Measure:
    summary = simulate(scenario).summary
    advance_s = summary["wall_time_s"]
    sim_s = summary["real_time_factor"] * advance_s  # the context's time at the end
    plans = summary.get("plans", [])
    return Measure(
        status=summary["status"],
        sim_s=sim_s,
        wall_s=summary["build_time_s"] + advance_s,
        advance_rtf=summary["real_time_factor"],
        steps=summary["integrator_steps"],
        plan_calls=len(plans),
        plan_s=sum(p["wall_time_s"] for p in plans),
        initial_plan_s=plans[0]["wall_time_s"] if plans else 0.0,
        initial_N=summary.get("initial_plan_N", 0),
        capture=summary.get("capture_success"),
    )


def cases(samples: int) -> list[tuple[str, object, object]]:
    """(name, soft-capture scenario, hold_point reference of the same duration) per run."""
    _, hold = load_scenario("hold_point")
    _, bundled = load_scenario("soft_capture")
    out = [("soft_capture (bundled)", bundled)]
    campaign = load_campaign(CAMPAIGN)
    for run in plan_runs(campaign)[:samples]:
        name = f"{CAMPAIGN} sample {run.sample_index}"
        out.append((name, apply_overrides(campaign.base, run.overrides)))
    return [
        (name, scenario, dataclasses.replace(hold, duration_s=scenario.duration_s))
        for name, scenario in out
    ]


def run_pairs(pairs, repeat: int, progress) -> tuple[list, list]:
    """Per pair: (soft-capture measures, reference measures), one each per repeat."""
    soft = [[] for _ in pairs]
    hold = [[] for _ in pairs]
    for r in range(repeat):
        shift = r % len(pairs)
        order = list(range(len(pairs)))[shift:] + list(range(len(pairs)))[:shift]
        for position, i in enumerate(order):
            name, scenario, reference = pairs[i]
            first_soft = (r + position) % 2 == 0
            for kind in ("soft", "hold") if first_soft else ("hold", "soft"):
                if kind == "soft":
                    soft[i].append(measure(scenario))
                else:
                    hold[i].append(measure(reference))
            progress(
                f"repeat {r + 1}/{repeat} {name}: soft capture RTF {soft[i][-1].rtf:.1f}, "
                f"hold_point RTF {hold[i][-1].rtf:.1f}"
            )
    return soft, hold


def med(values) -> float:
    return statistics.median(values)


def row_figures(soft: list[Measure], hold: list[Measure]) -> dict:
    """Medians over the repeats; ratios are medians of the paired (same-repeat) ratios."""
    return {
        "sim": med(m.sim_s for m in soft),
        "wall": med(m.wall_s for m in soft),
        "rtf": med(m.rtf for m in soft),
        "calls": med(m.plan_calls for m in soft),
        "plan": med(m.plan_s for m in soft),
        "initial": med(m.initial_plan_s for m in soft),
        "share": med(m.plan_s / m.wall_s for m in soft),
        "other": med(m.other_s for m in soft),
        "rtf_other": med(m.rtf_other for m in soft),
        "hold_wall": med(m.wall_s for m in hold),
        "hold_rtf": med(m.rtf for m in hold),
        "ratio": med(s.rtf / h.rtf for s, h in zip(soft, hold)),
        "cost_ratio": med((s.other_s / s.sim_s) / (h.wall_s / h.sim_s) for s, h in zip(soft, hold)),
        "advance_rtf": med(m.advance_rtf for m in soft),
        "steps_per_s": med(m.steps / m.sim_s for m in soft),
        "hold_steps_per_s": med(m.steps / m.sim_s for m in hold),
        "status": ", ".join(sorted({m.status for m in soft + hold})),
        "capture": all(m.capture for m in soft),
        "initial_N": soft[0].initial_N,
    }


def report(args, pairs, soft, hold, load_start, load_end, elapsed) -> str:
    command = "python benchmarks/bench_soft_capture_closed_loop.py " + " ".join(sys.argv[1:])
    rows = [row_figures(s, h) for s, h in zip(soft, hold)]
    out = ["# Closed-loop soft capture: real-time factor", ""]
    out.append(f"Machine: {machine_line()}.")
    out.append(f"Command: `{command.strip()}`; {elapsed:.0f} s in all.")
    shared = max(load_start[0], load_end[0]) > SHARED_LOAD
    loads = (
        f"1/5/15-minute load average {load_start[0]:.2f}/{load_start[1]:.2f}/"
        f"{load_start[2]:.2f} at the start and {load_end[0]:.2f}/{load_end[1]:.2f}/"
        f"{load_end[2]:.2f} at the end, on {os.cpu_count()} cores"
    )
    if shared:
        out.append(
            f"The machine was shared with other work ({loads}; this benchmark is one "
            "single-threaded process): wall times carry that noise. Each soft-capture run and "
            "its reference run were run back to back, in alternating and rotating order, so "
            "that the "
            "load hits both alike; the ratios are the figures to read."
        )
    else:
        out.append(f"Load: {loads}.")
    out += [
        "",
        (
            f"Each row: median of {args.repeat} repeats; ratios are medians of the per-repeat "
            "paired ratios. Wall = diagram build + `Initialize` (where the initial plan is made) + "
            "`AdvanceTo`. Reference: bundled `hold_point` (same truth, thrusters, allocator, "
            "10 Hz PWM, integrator; no planner) run for the same simulated time, paired with the "
            "row's run."
        ),
        "",
        "## Per run",
        "",
        (
            "| run | sim s | wall s | RTF | planner calls | planning s | initial plan s "
            "| planning share | non-planning s | RTF excl. planning | hold_point wall s "
            "| hold_point RTF | RTF ratio to hold_point | non-planning cost ratio to hold_point |"
        ),
        (
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: "
            "| ---: | ---: |"
        ),
    ]
    for (name, _, _), f in zip(pairs, rows):
        out.append(
            f"| {name} | {f['sim']:.0f} | {f['wall']:.2f} | {f['rtf']:.1f} | {f['calls']:g} "
            f"| {f['plan']:.2f} | {f['initial']:.2f} | {100 * f['share']:.1f}% "
            f"| {f['other']:.2f} | {f['rtf_other']:.1f} | {f['hold_wall']:.2f} "
            f"| {f['hold_rtf']:.1f} | {f['ratio']:.2f} | {f['cost_ratio']:.2f} |"
        )
    sampled_soft = [m for s in soft[1:] for m in s]
    sampled_rows = rows[1:]
    if sampled_rows:
        plan_total = sum(m.plan_s for m in sampled_soft)
        wall_total = sum(m.wall_s for m in sampled_soft)
        out += [
            "",
            f"## Summary over the {len(sampled_rows)} sampled runs of `{CAMPAIGN}`",
            "",
            "| quantity | value |",
            "| --- | ---: |",
            f"| median RTF | {med(f['rtf'] for f in sampled_rows):.1f} |",
            f"| median RTF excl. planning | {med(f['rtf_other'] for f in sampled_rows):.1f} |",
            (
                f"| median hold_point RTF (reference, same runs' load) "
                f"| {med(f['hold_rtf'] for f in sampled_rows):.1f} |"
            ),
            (
                f"| median RTF ratio, soft capture / hold_point "
                f"| {med(f['ratio'] for f in sampled_rows):.2f} |"
            ),
            (
                f"| median non-planning cost ratio (per simulated s), soft capture / hold_point "
                f"| {med(f['cost_ratio'] for f in sampled_rows):.2f} |"
            ),
            (
                f"| planning share of wall time (sum over runs and repeats) "
                f"| {100 * plan_total / wall_total:.1f}% |"
            ),
            (
                f"| median planning share of wall time, per run "
                f"| {100 * med(f['share'] for f in sampled_rows):.1f}% |"
            ),
            f"| planner calls per run (median) | {med(f['calls'] for f in sampled_rows):g} |",
            (
                f"| initial plan's share of planning time (sum) "
                f"| {100 * sum(m.initial_plan_s for m in sampled_soft) / plan_total:.1f}% |"
            ),
        ]
    out += [
        "",
        "## Details",
        "",
        (
            "Summary RTF: the summary's `real_time_factor`, which leaves out the diagram build "
            "(it counts `Initialize`, hence the initial plan). Integrator steps per simulated "
            "second compare "
            "the integration work of the two diagrams."
        ),
        "",
        (
            "| run | status | captured | initial plan N | summary RTF "
            "| steps per sim s | hold_point steps per sim s |"
        ),
        "| --- | --- | --- | ---: | ---: | ---: | ---: |",
    ]
    for (name, _, _), f in zip(pairs, rows):
        out.append(
            f"| {name} | {f['status']} | {'yes' if f['capture'] else 'no'} | {f['initial_N']} "
            f"| {f['advance_rtf']:.1f} | {f['steps_per_s']:.0f} | {f['hold_steps_per_s']:.0f} |"
        )
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--samples", type=int, default=6, help=f"sampled starts of {CAMPAIGN} (its first K)"
    )
    parser.add_argument("--repeat", type=int, default=2, help="runs per pair (median is kept)")
    args = parser.parse_args(argv)
    logging.getLogger("drake").setLevel(logging.WARNING)
    load_start = os.getloadavg()
    start = time.perf_counter()
    pairs = cases(args.samples)

    def progress(message):
        print(f"[{time.perf_counter() - start:6.1f} s] {message}", file=sys.stderr, flush=True)

    # Warm-up, untimed: first-call imports and caches of both diagrams and of the planner.
    measure(dataclasses.replace(pairs[0][1], duration_s=1.0))
    measure(dataclasses.replace(pairs[0][2], duration_s=1.0))
    soft, hold = run_pairs(pairs, args.repeat, progress)
    load_end = os.getloadavg()
    text = report(args, pairs, soft, hold, load_start, load_end, time.perf_counter() - start)
    print(text)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(text)
    print(f"written to {RESULTS}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
