"""Solve times of paper 003's approach planner (rpod.planners.planar_approach), per candidate
duration, for the Sec. V-A case and for case-study points.

    python benchmarks/bench_planar_nlp.py [--nlp-every-candidate] [--nlp-from-guess]

Prints the tables and writes them to benchmarks/results/planar_nlp.md. Every plan is
re-checked by `check_plan` (10 keep-out points per step, eq. 7 residual, body wrench against
planar_8 by allocation); "check" says whether it passed.

- Sec. V-A (theta_approach = 3 pi / 4, omega_target = 0.1 rad/s, 0.3 m target and chaser,
  10 kg, 0.15 kg m^2, planar_8 with F_thr = 0.3 N, start (1, 0) m at rest), dt = 0.1 s: each of
  the three candidate durations by the default method ("scp": attitude QP + translation QPs,
  Clarabel), and IPOPT and SNOPT on the joint NLP started from the SCP answer (the paper's
  formulation and solver, as a confirmation: time and cost against the SCP's) at the shortest
  candidate (N = 236), at every candidate with --nlp-every-candidate (~15 min: SNOPT took 10 min
  at N = 864).
- With --nlp-from-guess, also IPOPT and SNOPT from the spiral guess on the shortest candidate
  (N = 236): ~6 min, which is why "scp" is the default.
- Case-study points (Sec. V-D): omega_target in {0.1, 0.5, 1.0, 2.0} rad/s x F_thr in
  {0.03, 0.3, 1.02} N (planar_8 limits 2 F_thr per axis, 2 s F_thr in torque), the other
  settings as Sec. V-A; per point the three candidates' times and statuses, the chosen one and
  its terminal error.
Times are wall times of `plan_approach`'s per-candidate solves (program building included) on
a machine shared with other work (the load average is printed).
"""

import argparse
import dataclasses
import math
import os
import pathlib
import sys
import time

import numpy as np
from machine import machine_line, write_results  # benchmarks/machine.py, beside this script

from rpod.models.planar_approach import planar_8_wrench_limits
from rpod.planners.planar_approach import (
    PlanarApproachConfig,
    duration_candidates,
    plan_approach,
)
from rpod.planners.planar_approach_check import check_plan

RESULTS = pathlib.Path(__file__).parent / "results" / "planar_nlp.md"
X0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
OMEGAS = (0.1, 0.5, 1.0, 2.0)
THRUSTS = (0.03, 0.3, 1.02)


def _config(omega: float = 0.1, thrust: float = 0.3, **changes) -> PlanarApproachConfig:
    max_force, max_torque = planar_8_wrench_limits(0.3, thrust)
    return PlanarApproachConfig(
        omega_target_rad_s=omega, max_force_N=max_force, max_torque_Nm=max_torque, **changes
    )


def _plan_row(config: PlanarApproachConfig, duration: float) -> tuple:
    """One candidate as a one-candidate plan (so that check_plan sees it)."""
    one = dataclasses.replace(
        config,
        duration_min_s=duration - 1e-6,
        duration_max_s=duration + 1e-6,
        max_duration_candidates=1,
    )
    start = time.perf_counter()
    plan = plan_approach(one, X0)
    wall = time.perf_counter() - start
    record = plan.candidates[0]
    report = check_plan(plan, one) if plan.success else {"passed": False}
    return plan, record, report, wall


def sec_v_a(lines: list[str], every_candidate: bool, from_guess: bool) -> None:
    config = _config()
    lines += [
        "## Sec. V-A, per candidate duration (dt = 0.1 s)",
        "",
        (
            "IPOPT and SNOPT from the SCP answer: their solve time includes the SCP's; their "
            "iterations are NLP solves (2 when the first answer changed the KOS labels)."
        ),
        "",
        (
            "| T (s) | N | method | status | iterations | solve time (s) | cost J | goal / kinetic "
            "/ control | terminal error (m) | terminal speed (m/s) | check |"
        ),
        "| ---: | ---: | --- | --- | ---: | ---: | ---: | --- | ---: | ---: | --- |",
    ]
    for index, duration in enumerate(duration_candidates(config)):
        N = math.ceil(duration / config.dt_s - 1e-9)
        methods = [("scp", {})]
        if index == 0 or every_candidate:
            methods += [("ipopt", {"solver": "ipopt"}), ("snopt", {"solver": "snopt"})]
        for name, changes in methods:
            label = name if name == "scp" else f"{name} from SCP"
            plan, record, report, _ = _plan_row(_config(**changes), duration)
            terms = plan.cost_terms
            lines.append(
                f"| {duration:.2f} | {N} | {label} | {record.status.value} | "
                f"{record.iterations} | {record.solve_time_s:.2f} | {record.cost:.4f} | "
                + (
                    f"{terms['goal']:.4f} / {terms['kinetic']:.4f} / {terms['control']:.4f} | "
                    f"{report['terminal_position_error_m']:.4f} | "
                    f"{report['terminal_speed_m_s']:.4f} | "
                    if plan.success
                    else "- | - | - | "
                )
                + f"{'pass' if report['passed'] else 'FAIL'} |"
            )
            print(lines[-1], flush=True)
    if from_guess:
        duration = duration_candidates(config)[0]
        for name in ("ipopt", "snopt"):
            guess_config = _config(solver=name, nlp_warm_start="guess")
            plan, record, report, _ = _plan_row(guess_config, duration)
            lines.append(
                f"| {duration:.2f} | 236 | {name} from guess | {record.status.value} | "
                f"{record.iterations} | {record.solve_time_s:.2f} | {record.cost:.4f} | - | "
                + (
                    f"{report['terminal_position_error_m']:.4f} | "
                    f"{report['terminal_speed_m_s']:.4f} | "
                    if plan.success
                    else "- | - | "
                )
                + f"{'pass' if report['passed'] else 'FAIL'} ({record.solver_message}) |"
            )
            print(lines[-1], flush=True)
    lines.append("")


def case_study(lines: list[str]) -> None:
    lines += [
        "## Case-study points: solve time per candidate (scp, dt = 0.1 s)",
        "",
        "Per candidate: T (s): status, SCP iterations, solve time (s), cost J.",
        "",
        (
            "| omega (rad/s) | F_thr (N) | candidate 1 | candidate 2 | candidate 3 | chosen T (s) "
            "| terminal error (m) | terminal speed (m/s) | total (s) | check |"
        ),
        "| ---: | ---: | --- | --- | --- | ---: | ---: | ---: | ---: | --- |",
    ]
    for omega in OMEGAS:
        for thrust in THRUSTS:
            config = _config(omega, thrust)
            start = time.perf_counter()
            plan = plan_approach(config, X0)
            total = time.perf_counter() - start
            cells = [
                f"{c.duration_s:.2f}: {c.status.value}, {c.iterations}, {c.solve_time_s:.2f}, "
                f"{c.cost:.3g}"
                for c in plan.candidates
            ]
            cells += ["-"] * (3 - len(cells))
            if plan.success:
                report = check_plan(plan, config)
                tail = (
                    f"{plan.duration_s:.2f} | {report['terminal_position_error_m']:.3f} | "
                    f"{report['terminal_speed_m_s']:.3f} | {total:.2f} | "
                    f"{'pass' if report['passed'] else 'FAIL'}"
                )
            else:
                tail = f"- | - | - | {total:.2f} | {plan.status.value}"
            lines.append(f"| {omega} | {thrust} | " + " | ".join(cells) + f" | {tail} |")
            print(lines[-1], flush=True)
    lines.append("")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--nlp-every-candidate",
        action="store_true",
        help="IPOPT and SNOPT from the SCP answer at every candidate, not only the shortest",
    )
    parser.add_argument(
        "--nlp-from-guess",
        action="store_true",
        help="also time IPOPT and SNOPT from the spiral guess at N = 236 (minutes)",
    )
    args = parser.parse_args()
    load_start = os.getloadavg()
    start = time.perf_counter()
    lines = [
        "# Paper 003 approach planner: solve time per candidate duration",
        "",
        f"Machine: {machine_line()}.",
        "",
    ]
    body: list[str] = []
    sec_v_a(body, args.nlp_every_candidate, args.nlp_from_guess)
    case_study(body)
    load_end = os.getloadavg()
    command = "python benchmarks/bench_planar_nlp.py"
    if args.nlp_every_candidate:
        command += " --nlp-every-candidate"
    if args.nlp_from_guess:
        command += " --nlp-from-guess"
    lines += [
        (
            f"Command: `{command}`; {time.perf_counter() - start:.0f} s in all. "
            f"Load average (1/5/15 min) {'/'.join(f'{x:.2f}' for x in load_start)} at the start, "
            f"{'/'.join(f'{x:.2f}' for x in load_end)} at the end, on {os.cpu_count()} cores."
        ),
        "",
        *body,
    ]
    write_results(RESULTS, lines)
    return 0


if __name__ == "__main__":
    sys.exit(main())
