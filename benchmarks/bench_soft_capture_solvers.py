"""Paper 000's soft-capture programs at their floor (issue 23), in one run: Clarabel as before
(the program in SI, Clarabel's default iterative refinement), Clarabel on the program in units
without and with refinement (rpod's default: without), and ECOS and QOCO from their own packages
on the program in units.

    python benchmarks/bench_soft_capture_solvers.py [--starts 12] [--repeats 3] [--plans 30]
                                                    [--seed 7]

Prints three tables and writes them to benchmarks/results/soft_capture_solvers.md:

- Problem 2 at N = 100 over Sec. VI-B-like starts (rpod.planners.soft_capture
  .sample_sec_vib_start), and at N = 40, where most of those starts are infeasible (the horizon
  search's first tries): per solver, the status, iterations, wall time of `solve` (per-solve
  data rewrite and read-back included, as the planner pays it) and the optimal cost against the
  reference (Clarabel on the program in SI, as before issue 23). The variants run interleaved,
  in an order rotated from repeat to repeat, so that load hits each alike. "Agrees": the same
  status and the optimal cost within 1e-6 relative of the reference, on every start.
- One SCP iteration at N = 100 from each start's Problem 2 solution: the linearisation (the
  pointing law, the collision metric alpha with its gradient at every knot, the pointing
  Jacobian, `set_linearisation`), with the alpha LPs solved one knot at a time (before issue
  23) and as one LP (`ScalingMetricProgram.evaluate_many`), then the Problem 3 solve per
  solver.
- A whole plan (`SoftCapturePlanner.plan`, the horizon search from N = 40) from `--plans`
  Sec. VI-B-like starts, per solver, its programs built beforehand (every row's SCP
  linearisation is the one-LP one).

Goals (issue 23): Problem 2 at N = 100 at most 10 ms median, one SCP iteration at most 20 ms,
a plan at most 50 ms median, each with the same optimum (1e-6 relative) and status.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.metadata
import os
import pathlib
import sys
import time

import numpy as np
from bench_soft_capture import horizon_data, table  # benchmarks/, beside this script
from machine import machine_line

from rpod.models.collision import ScalingMetricProgram
from rpod.models.shapes import soft_capture_chaser_hull, soft_capture_target_hull
from rpod.planners.pointing import pointing_attitudes, pointing_rotation_jacobian
from rpod.planners.soft_capture import (
    SoftCaptureConfig,
    SoftCapturePlanner,
    sample_sec_vib_start,
)
from rpod.planners.soft_capture_socp import SoftCaptureSocp

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "soft_capture_solvers.md"
COST_RTOL = 1e-6
# (label, config overrides); the first is the reference.
VARIANTS = (
    ("Clarabel, SI (before)", {"socp_scaled": False, "socp_iterative_refinement": True}),
    ("Clarabel, units", {}),
    ("Clarabel, units, refined", {"socp_iterative_refinement": True}),
    ("ECOS, units", {"socp_solver": "ecos"}),
    ("QOCO, units", {"socp_solver": "qoco"}),
)
GOAL_P2_MS, GOAL_SCP_MS, GOAL_PLAN_MS = 10.0, 20.0, 50.0


def rotated(items, shift: int):
    shift %= len(items)
    return items[shift:] + items[:shift]


def percentile(values, q) -> float:
    return float(np.percentile(values, q)) if len(values) else float("nan")


def bench_problem2(config, starts, N: int, repeats: int):
    """Per variant: the solves of Problem 2 at N over the starts, interleaved."""
    programs = {
        label: SoftCaptureSocp(dataclasses.replace(config, **overrides), N, False)
        for label, overrides in VARIANTS
    }
    runs = {label: [] for label, _ in VARIANTS}
    labels = [label for label, _ in VARIANTS]
    for index, (x0, prediction) in enumerate(starts):
        data, _ = horizon_data(config, x0, prediction, N)
        for repeat in range(repeats):
            for label in rotated(labels, index + repeat):
                program = programs[label]
                start = time.perf_counter()
                program.set_data(data)
                solution = program.solve()
                wall = time.perf_counter() - start
                runs[label].append((index, solution, wall))
    return runs


def problem2_rows(runs):
    reference = {index: solution for index, solution, _ in runs[VARIANTS[0][0]]}
    rows = []
    for label, _ in VARIANTS:
        walls = [wall for _, _, wall in runs[label]]
        iterations = [solution.iterations for _, solution, _ in runs[label]]
        solved = {index for index, solution, _ in runs[label] if solution.success}
        same_status, worst = 0, 0.0
        for index, solution, _ in runs[label]:
            ref = reference[index]
            same_status += solution.solution_result == ref.solution_result
            if solution.success and ref.success:
                worst = max(worst, abs(solution.cost - ref.cost) / abs(ref.cost))
        agrees = same_status == len(runs[label]) and worst <= COST_RTOL
        rows.append(
            {
                "label": label,
                "solves": len(runs[label]),
                "solved": len(solved),
                "starts": len(reference),
                "status": f"{same_status}/{len(runs[label])}",
                "words": sorted({s.solver_status for _, s, _ in runs[label]}),
                "iterations": (
                    float(np.median(iterations)),
                    int(np.min(iterations)),
                    int(np.max(iterations)),
                ),
                "median": 1e3 * float(np.median(walls)),
                "p90": 1e3 * percentile(walls, 90),
                "worst_cost": worst,
                "agrees": agrees,
            }
        )
    base = rows[0]["median"]
    for row in rows:
        row["ratio"] = row["median"] / base
    return rows


def bench_scp(config, starts, N: int):
    """One SCP iteration per start from its Problem 2 solution, per variant."""
    metric = ScalingMetricProgram(soft_capture_chaser_hull(), soft_capture_target_hull())
    axis_C = np.asarray(config.p_CDc_C, dtype=float)
    problem2 = SoftCaptureSocp(config, N, False)
    problems3 = {
        label: SoftCaptureSocp(dataclasses.replace(config, **overrides), N, True)
        for label, overrides in VARIANTS
    }
    labels = [label for label, _ in VARIANTS]
    times = {"one": [], "many": [], "alpha_one": [], "alpha_many": [], "alpha_diff": 0.0}
    solves = {label: [] for label in labels}
    for index, (x0, prediction) in enumerate(starts):
        data, R_LT = horizon_data(config, x0, prediction, N)
        problem2.set_data(data)
        solution = problem2.solve()
        if not solution.success:
            continue
        r = solution.x[:, :3]
        origin = np.zeros(3)
        alphas = {}
        for way in rotated(["one", "many"], index):
            w0 = time.perf_counter()
            R_LC = pointing_attitudes(r, axis_C, None)
            w1 = time.perf_counter()
            if way == "one":
                metrics = [metric.evaluate(R_LC[k], r[k], R_LT[k], origin) for k in range(N)]
            else:
                metrics = metric.evaluate_many(R_LC, r, R_LT, np.zeros((N, 3)))
            w2 = time.perf_counter()
            alpha = alphas[way] = np.array([m.alpha for m in metrics])
            grad_p = np.array([m.d_alpha_d_p_a for m in metrics])
            grad_theta = np.array([m.d_alpha_d_theta_a for m in metrics])
            dtheta_dr = pointing_rotation_jacobian(r, axis_C, None)
            J = grad_p + np.einsum("ki,kij->kj", grad_theta, dtheta_dr)
            J[0] = 0.0
            timed = problems3[VARIANTS[1][0]]  # the planner writes into one program
            timed.set_data(data)
            timed.set_linearisation(alpha, J, r)
            w3 = time.perf_counter()
            times[way].append(w3 - w0)
            times[f"alpha_{way}"].append(w2 - w1)
        difference = np.max(np.abs(alphas["many"] - alphas["one"]) / alphas["one"])
        times["alpha_diff"] = max(times["alpha_diff"], float(difference))
        for program in problems3.values():  # the same rows for every solver, untimed
            program.set_data(data)
            program.set_linearisation(alpha, J, r)
        for label in rotated(labels, index):
            start = time.perf_counter()
            result = problems3[label].solve()
            solves[label].append((index, result, time.perf_counter() - start))
    return times, solves


def bench_plans(config, starts):
    """Whole plans per variant, programs built beforehand; interleaved per start."""
    planners = {}
    build = {}
    for label, overrides in VARIANTS:
        planner = SoftCapturePlanner(dataclasses.replace(config, **overrides))
        start = time.perf_counter()
        for N in planner.config.horizon_grid():
            planner.programs(N)
        build[label] = time.perf_counter() - start
        planners[label] = planner
    plans = {label: [] for label, _ in VARIANTS}
    labels = [label for label, _ in VARIANTS]
    for index, (x0, prediction) in enumerate(starts):
        for label in rotated(labels, index):
            start = time.perf_counter()
            plan = planners[label].plan(x0, prediction)
            plans[label].append((index, plan, time.perf_counter() - start))
    return build, plans


def problem2_table(rows) -> str:
    return table(
        [
            "solver",
            "solves",
            "starts solved",
            "same status as the reference",
            "iterations median [min-max]",
            "median (ms)",
            "p90 (ms)",
            "median / reference",
            "largest cost difference (relative)",
            "agrees",
        ],
        [
            [
                row["label"],
                str(row["solves"]),
                f"{row['solved']}/{row['starts']}",
                row["status"],
                f"{row['iterations'][0]:g} [{row['iterations'][1]}-{row['iterations'][2]}]",
                f"{row['median']:.1f}",
                f"{row['p90']:.1f}",
                f"{row['ratio']:.2f}",
                f"{row['worst_cost']:.1e}",
                "yes" if row["agrees"] else "NO",
            ]
            for row in rows
        ],
    )


def versions() -> str:
    names = ("drake", "clarabel", "ecos", "qoco")
    found = []
    for name in names:
        try:
            found.append(f"{name} {importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            found.append(f"{name} not installed")
    return ", ".join(found)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--starts", type=int, default=12, help="starts for Problems 2 and 3")
    parser.add_argument("--repeats", type=int, default=3, help="timed solves per start")
    parser.add_argument("--plans", type=int, default=30, help="starts for whole plans")
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    load_start = os.getloadavg()
    began = time.perf_counter()
    config = SoftCaptureConfig()
    rng = np.random.default_rng(args.seed)
    starts = [sample_sec_vib_start(rng, config) for _ in range(args.starts)]
    plan_starts = [sample_sec_vib_start(rng, config) for _ in range(args.plans)]

    p2 = {N: problem2_rows(bench_problem2(config, starts, N, args.repeats)) for N in (100, 40)}
    print("  Problem 2: done", file=sys.stderr)
    scp_times, scp_solves = bench_scp(config, starts, 100)
    print("  SCP iteration: done", file=sys.stderr)
    build, plans = bench_plans(config, plan_starts)
    print("  plans: done", file=sys.stderr)
    load_end = os.getloadavg()

    command = "python benchmarks/bench_soft_capture_solvers.py " + " ".join(sys.argv[1:])
    out = ["# Soft-capture programs: solvers and scaling (issue 23)", ""]
    out.append(f"Machine: {machine_line()}; {versions()}.")
    out.append(f"Command: `{command.strip()}`; {time.perf_counter() - began:.0f} s in all.")
    out.append(
        f"1/5/15-minute load average {load_start[0]:.2f}/{load_start[1]:.2f}/"
        f"{load_start[2]:.2f} at the start and {load_end[0]:.2f}/{load_end[1]:.2f}/"
        f"{load_end[2]:.2f} at the end, on {os.cpu_count()} cores. Reference: the first "
        "solver (Clarabel through Drake on the program in SI, as before issue 23); ratios "
        "are to it, measured in this run."
    )
    for N, what in ((100, "feasible starts"), (40, "mostly infeasible: the search's first try")):
        out += ["", f"## Problem 2 at N = {N} ({what}; {args.starts} starts x {args.repeats})", ""]
        out.append(problem2_table(p2[N]))
    out += [
        "",
        "Status words met: "
        + "; ".join(f"{row['label']}: {', '.join(row['words'])}" for row in p2[40])
        + ".",
    ]

    out += ["", f"## One SCP iteration at N = 100 ({len(scp_times['one'])} starts)", ""]
    lin_one, lin_many = (1e3 * np.median(scp_times[w]) for w in ("one", "many"))
    a_one, a_many = (1e3 * np.median(scp_times[f"alpha_{w}"]) for w in ("one", "many"))
    out.append(
        f"Linearisation, median: {lin_one:.1f} ms with one alpha LP per knot (of which the "
        f"LPs {a_one:.1f} ms), {lin_many:.1f} ms with one LP for all knots (the LPs "
        f"{a_many:.1f} ms): {a_one / a_many:.1f}x on the LPs; alpha equal to "
        f"{scp_times['alpha_diff']:.1e} relative."
    )
    reference = {index: s for index, s, _ in scp_solves[VARIANTS[0][0]]}
    rows = []
    for label, _ in VARIANTS:
        walls = [w for _, _, w in scp_solves[label]]
        worst = max(
            (
                abs(s.cost - reference[i].cost) / abs(reference[i].cost)
                for i, s, _ in scp_solves[label]
                if s.success and reference[i].success
            ),
            default=float("nan"),
        )
        same = sum(
            s.solution_result == reference[i].solution_result for i, s, _ in scp_solves[label]
        )
        iteration = 1e3 * np.median(walls) + lin_many
        rows.append(
            [
                label,
                f"{same}/{len(walls)}",
                f"{np.median([s.iterations for _, s, _ in scp_solves[label]]):g}",
                f"{1e3 * np.median(walls):.1f}",
                f"{1e3 * percentile(walls, 90):.1f}",
                f"{worst:.1e}",
                f"{iteration:.1f}",
                "yes" if iteration <= GOAL_SCP_MS else "no",
            ]
        )
    out += [
        "",
        table(
            [
                "solver",
                "same status",
                "iterations (median)",
                "Problem 3 median (ms)",
                "p90 (ms)",
                "largest cost difference",
                "iteration: one-LP linearisation + Problem 3 (ms)",
                f"<= {GOAL_SCP_MS:g} ms",
            ],
            rows,
        ),
    ]

    out += ["", f"## Whole plans ({args.plans} Sec. VI-B-like starts)", ""]
    reference = {index: plan for index, plan, _ in plans[VARIANTS[0][0]]}
    rows = []
    for label, _ in VARIANTS:
        walls = [w for _, _, w in plans[label]]
        same = sum(
            p.status == reference[i].status and p.N == reference[i].N for i, p, _ in plans[label]
        )
        statuses = sorted({p.status for _, p, _ in plans[label]})
        rows.append(
            [
                label,
                f"{build[label]:.2f}",
                f"{same}/{len(walls)}",
                ", ".join(statuses),
                f"{1e3 * np.median(walls):.0f}",
                f"{1e3 * percentile(walls, 90):.0f}",
                f"{np.median(walls) / np.median([w for _, _, w in plans[VARIANTS[0][0]]]):.2f}",
            ]
        )
    out.append(
        table(
            [
                "solver",
                "programs built (s, once)",
                "same status and N as the reference",
                "statuses",
                "plan median (ms)",
                "plan p90 (ms)",
                "median / reference",
            ],
            rows,
        )
    )
    text = "\n".join(out) + "\n"
    print(text)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
