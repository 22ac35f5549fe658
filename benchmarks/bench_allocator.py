"""Cost of the wrench allocation and of the thruster bank, before and after, in one run.

    python benchmarks/bench_allocator.py [--cases N] [--repeat R] [--duration S]

Prints a table and writes it to benchmarks/results/allocator.txt. "Before" is the code this
replaced, run in the same process on the same inputs:
- allocation: `allocate_duty_reference` (scipy bvls + HiGHS LP + polish, the former body of
  `allocate_duty`) against `DutyAllocator.solve` (enumerated optimal bases + active-set box
  least squares) and `allocate_duty` (the same behind a per-(B, weights, fuel_cost) cache);
- the WrenchAllocator system (one Eval per new input) with its solver swapped for the reference;
- ThrusterBank._calc_clipped and a full output evaluation, against the former _calc_clipped
  (copied below);
- for information: one LP through a Drake MathematicalProgram built once, its equality bounds
  updated per call and solved by ClpSolver (the option considered and not taken);
- end to end: the bundled hold_point scenario, shortened to --duration s, with the allocator
  and bank as they were and as they are.
Timings: every case runs R times, before and after interleaved; the table gives the median of
the R per-call means (us) and the ratio before/after of those medians. The cases are random
wrenches (seeded): "feasible" = B u for u in the box with ~30 % of thrusters off, "infeasible"
= N(0, 1) directions scaled to 0.5-10x the largest full-on wrench component. The script also
checks that both paths agree (fit and fuel), so a fast wrong answer cannot pass unnoticed.
"""

import argparse
import dataclasses
import logging
import pathlib
import platform
import statistics
import time

import numpy as np
from machine import write_results  # benchmarks/machine.py, beside this script
from pydrake.common.value import AbstractValue
from pydrake.solvers import ClpSolver, MathematicalProgram

from rpod.models.thrusters import (
    DutyAllocator,
    allocate_duty,
    allocate_duty_reference,
    planar_8,
    rcs_cube_12,
    wrench_matrix,
)
from rpod.systems.allocator import WrenchAllocator
from rpod.systems.thruster_bank import ThrusterBank

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "allocator.txt"


def wrenches(B: np.ndarray, kind: str, count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    n = B.shape[1]
    if kind == "feasible":
        return [B @ (rng.uniform(0, 1, n) * (rng.uniform(size=n) < 0.7)) for _ in range(count)]
    scale = np.abs(B).sum(axis=1).max()
    return [rng.normal(size=6) * rng.choice([0.5, 2.0, 10.0]) * scale for _ in range(count)]


def per_call_us(functions: dict, inputs: list, repeat: int) -> dict:
    """Median over `repeat` rounds of the mean time per call, us; functions interleaved."""
    samples = {name: [] for name in functions}
    for function in functions.values():
        function(inputs[0])  # warm-up: first-call costs are not per-call costs
    for _ in range(repeat):
        for name, function in functions.items():
            start = time.perf_counter()
            for x in inputs:
                function(x)
            samples[name].append((time.perf_counter() - start) / len(inputs) * 1e6)
    return {name: statistics.median(values) for name, values in samples.items()}


def check_agreement(B, c, inputs) -> tuple[float, float]:
    """Largest relative wrench difference and fuel excess (new - reference, scaled c)."""
    allocator = DutyAllocator(B, None, c)
    fit, fuel = 0.0, -np.inf
    cn = c / c.max()
    for w in inputs:
        u, u_ref = allocator.solve(w), allocate_duty_reference(B, w, fuel_cost=c)
        scale = np.linalg.norm(w) + np.linalg.norm(B @ u_ref)
        fit = max(fit, np.linalg.norm(B @ (u - u_ref)) / scale)
        fuel = max(fuel, cn @ u - cn @ u_ref)
    assert fit < 1e-9 and fuel < 1e-9 and allocator.fallback_count == 0, (fit, fuel)
    return fit, fuel


class ReferenceSolver:
    """Stands in for a DutyAllocator, answering with the scipy reference (the old system)."""

    def __init__(self, B, c):
        self._B, self._c = B, c

    def solve(self, w, minimize_fuel=True):
        return allocate_duty_reference(self._B, w, minimize_fuel=minimize_fuel, fuel_cost=self._c)


def old_calc_clipped(self, context, value):
    """ThrusterBank._calc_clipped as it was (fixed-layout branch, for the comparison)."""
    command = self._command_port.Eval(context)
    stored = value.get_mutable_value()
    m = self._layout.command_size
    violation = np.maximum(np.maximum(-command, command - 1.0), 0.0)
    nan = np.isnan(command)
    if np.any(nan):
        violation[nan] = np.inf
        command = np.where(nan, 0.0, command)
    np.clip(command, 0.0, 1.0, out=stored[:m])
    stored[m:] = violation > self._report_tolerance


def drake_clp_lp(B, c):
    """The LP stage alone with a Drake program built once (equality bounds updated per call)."""
    U, s, Vt = np.linalg.svd(B, full_matrices=False)
    prog = MathematicalProgram()
    u = prog.NewContinuousVariables(B.shape[1], "u")
    prog.AddLinearCost(c / c.max(), 0.0, u)
    equality = prog.AddLinearEqualityConstraint(Vt, np.zeros(6), u)
    prog.AddBoundingBoxConstraint(0.0, 1.0, u)
    solver = ClpSolver()

    def solve(w):
        b = (U.T @ w) / s
        equality.evaluator().UpdateLowerBound(b)
        equality.evaluator().UpdateUpperBound(b)
        return solver.Solve(prog).GetSolution(u)

    return solve


def allocation_rows(cases: int, repeat: int) -> list[tuple]:
    rows = []
    for name, layout in (
        ("rcs_cube_12(1.5, 10, 220)", rcs_cube_12(1.5, 10.0, 220.0)),
        ("planar_8()", planar_8()),
    ):
        B, c = wrench_matrix(layout), layout.max_mass_flows_kg_s
        start = time.perf_counter()
        allocator = DutyAllocator(B, None, c)
        build_ms = (time.perf_counter() - start) * 1e3
        rows.append(
            (
                f"{name}: DutyAllocator set-up ({allocator.basis_count} bases), once",
                None,
                build_ms * 1e3,
                None,
            )
        )
        for kind in ("feasible", "infeasible"):
            inputs = wrenches(B, kind, cases, seed=1 if kind == "feasible" else 2)
            fit, fuel = check_agreement(B, c, inputs)
            allocate_duty(B, inputs[0], fuel_cost=c)  # builds its cached allocator (untimed)
            t = per_call_us(
                {
                    "reference": lambda w, B=B, c=c: allocate_duty_reference(B, w, fuel_cost=c),
                    "solver": allocator.solve,
                    "function": lambda w, B=B, c=c: allocate_duty(B, w, fuel_cost=c),
                },
                inputs,
                repeat,
            )
            label = f"{name}, {kind} (fit diff {fit:.0e}, fuel diff {fuel:+.0e})"
            rows.append((f"{label}: DutyAllocator.solve", t["reference"], t["solver"], None))
            rows.append((f"{name}, {kind}: allocate_duty", t["reference"], t["function"], None))
            if kind == "feasible":
                clp = per_call_us({"clp": drake_clp_lp(B, c)}, inputs, repeat)["clp"]
                rows.append(
                    (
                        f"{name}, {kind}: [info] LP only, prebuilt Drake program + Clp",
                        t["reference"],
                        clp,
                        None,
                    )
                )
    return rows


def system_rows(cases: int, repeat: int) -> list[tuple]:
    rows = []
    layout = rcs_cube_12(1.5, 10.0, 220.0)
    B, c = wrench_matrix(layout), layout.max_mass_flows_kg_s
    for kind in ("feasible", "infeasible"):
        inputs = wrenches(B, kind, cases, seed=3)
        timings = {}
        for which in ("before", "after"):
            system = WrenchAllocator(layout)
            if which == "before":
                system._solver = ReferenceSolver(B, c)
            context = system.CreateDefaultContext()
            fixed = system.get_input_port().FixValue(context, np.zeros(6))
            port = system.get_output_port()

            def evaluate(w, fixed=fixed, port=port, context=context):
                fixed.GetMutableData().set_value(w)  # a new input invalidates the cache
                port.Eval(context)

            timings[which] = evaluate
        t = per_call_us(timings, inputs, repeat)
        rows.append((f"WrenchAllocator Eval, rcs_cube_12, {kind}", t["before"], t["after"], None))

    for layout_name, bank_layout in (("rcs_cube_12", layout),):
        commands = [
            (np.random.default_rng(k).uniform(size=12) < 0.3).astype(float) for k in range(cases)
        ]
        banks = {"before": ThrusterBank(bank_layout), "after": ThrusterBank(bank_layout)}
        banks["before"]._calc_clipped = old_calc_clipped.__get__(banks["before"])
        clipped, full = {}, {}
        for which, bank in banks.items():
            context = bank.CreateDefaultContext()
            fixed = bank.get_input_port(0).FixValue(context, np.zeros(12))
            value = AbstractValue.Make(np.zeros(bank._clipped_size))
            outputs = [
                bank.GetOutputPort(p)
                for p in ("body_wrench", "propellant_mass_flow", "command_clipped")
            ]

            def calc(u, bank=bank, fixed=fixed, context=context, value=value):
                fixed.GetMutableData().set_value(u)
                bank._calc_clipped(context, value)

            def evaluate(u, fixed=fixed, context=context, outputs=outputs):
                fixed.GetMutableData().set_value(u)
                for output in outputs:
                    output.Eval(context)

            clipped[which], full[which] = calc, evaluate
        t = per_call_us(clipped, commands, repeat)
        rows.append(
            (
                f"ThrusterBank._calc_clipped, {layout_name}, PWM on/off command",
                t["before"],
                t["after"],
                None,
            )
        )
        t = per_call_us(full, commands, repeat)
        rows.append(
            (
                f"ThrusterBank, 3 outputs per new command, {layout_name}",
                t["before"],
                t["after"],
                None,
            )
        )
    return rows


def closed_loop_rows(duration_s: float) -> list[tuple]:
    """The hold_point scenario, shortened: whole-simulation wall time before and after."""
    from rpod.diagrams.simulate import simulate
    from rpod.scenarios.loader import load_scenario

    _, scenario = load_scenario("hold_point")
    scenario = dataclasses.replace(scenario, duration_s=duration_s)
    originals = (DutyAllocator.solve, ThrusterBank._calc_clipped)
    counts = {"calls": 0, "infeasible": 0}
    fast_solve = DutyAllocator.solve

    def reference_solve(self, w, minimize_fuel=True):
        return allocate_duty_reference(
            self._B, w, self._weights, minimize_fuel=minimize_fuel, fuel_cost=self._fuel_cost
        )

    def counting_solve(self, w, minimize_fuel=True):
        counts["calls"] += 1
        if self._fuel_minimal((self._T @ np.asarray(w, float)) * self._inv_s) is None:
            counts["infeasible"] += 1
        return fast_solve(self, w, minimize_fuel)

    walls = {}
    try:
        DutyAllocator.solve = counting_solve
        simulate(scenario)  # warm-up (imports, first-call costs) and allocation statistics
        for which in ("before", "after", "before", "after"):
            if which == "before":
                DutyAllocator.solve, ThrusterBank._calc_clipped = reference_solve, old_calc_clipped
            else:
                DutyAllocator.solve, ThrusterBank._calc_clipped = originals
            summary = simulate(scenario).summary
            walls.setdefault(which, []).append(summary["wall_time_s"])
    finally:
        DutyAllocator.solve, ThrusterBank._calc_clipped = originals
    before, after = min(walls["before"]), min(walls["after"])
    share = counts["infeasible"] / max(counts["calls"], 1)
    return [
        (
            (
                f"hold_point scenario, {duration_s:.0f} s simulated, whole run (s, best of 2; "
                f"{counts['calls']} allocations, {100 * share:.0f} % infeasible)"
            ),
            before * 1e6,
            after * 1e6,
            "s",
        )
    ]


def format_table(rows: list[tuple]) -> list[str]:
    width = max(len(r[0]) for r in rows)
    lines = [
        f"{'case':<{width}}  {'before':>10}  {'after':>10}  {'ratio':>7}",
        f"{'':-<{width}}  {'':->10}  {'':->10}  {'':->7}",
    ]
    for name, before, after, unit in rows:
        scale, suffix = (1e-6, " s") if unit == "s" else (1.0, " us")
        b = "" if before is None else f"{before * scale:.1f}{suffix}"
        a = f"{after * scale:.1f}{suffix}"
        ratio = "" if before is None else f"{before / after:.1f}x"
        lines.append(f"{name:<{width}}  {b:>10}  {a:>10}  {ratio:>7}")
    return lines


def main():
    logging.getLogger("drake").setLevel(logging.WARNING)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=200, help="random wrenches per case")
    parser.add_argument("--repeat", type=int, default=5, help="interleaved rounds per case")
    parser.add_argument(
        "--duration",
        type=float,
        default=60.0,
        help="simulated seconds of the closed-loop case (0: skip it)",
    )
    args = parser.parse_args()
    rows = allocation_rows(args.cases, args.repeat) + system_rows(args.cases, args.repeat)
    if args.duration > 0:
        rows += closed_loop_rows(args.duration)
    lines = [
        (
            "Wrench allocation and thruster bank: before (scipy reference, former bank code) vs "
            "after, same run."
        ),
        (
            f"Machine: {platform.processor() or platform.machine()}, Python "
            f"{platform.python_version()}; `python benchmarks/bench_allocator.py --cases "
            f"{args.cases} --repeat {args.repeat} --duration {args.duration:g}`; per-call times are "
            f"medians of {args.repeat} interleaved rounds of {args.cases} calls."
        ),
        "",
        *format_table(rows),
    ]
    write_results(RESULTS, lines)


if __name__ == "__main__":
    main()
