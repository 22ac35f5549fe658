"""Per-step time of paper 004's MPC (eq. 11) against raw OSQP on the identical QPs, same run.

The QPs are the real ones: `los_corridor` is flown once in closed loop (J2 truth, the exact
Jacobian of the one-step map as the model, so A_d and B_d change every step) and the data of
every MPC step (x_k, x_ref, u_{-1}, u_nom, A_d, B_d) is recorded. They are then replayed, step
by step, into (a) a fresh `LosCorridorMpc` (`solve`: data built in Python, OSQP's update path
for q, l, u and the A_d, B_d values, the shifted warm start, the rollout check of an unfinished
iterate) and (b) a raw OSQP problem of the identical QP, set up once and fed the same data
precomputed, through its own update path (update(q, l, u, Ax) and a warm solve): the floor of
the update path. Both see the same QPs; ratios are per step, same run.

Cases: the single-scenario configuration (N_p = 40, R_du = 1e4 I, 600 s) and the Monte Carlo
one (N_p = 20, R_du = diag(1e5, 1e4, 1e5), 400 s), each flown from los_corridor's start.
Goal (issue 10): at most 1.5x raw, and a p99 under 3 ms here.

    python benchmarks/bench_los_corridor_mpc.py

Writes benchmarks/results/los_corridor_mpc.md.
"""

import dataclasses
import os
import pathlib
import sys
import time

import numpy as np
import osqp
from machine import machine_line, write_results  # benchmarks/machine.py, beside this script

from rpod.diagrams.simulate import simulate
from rpod.planners import los_corridor_mpc
from rpod.planners.los_corridor_mpc import LosCorridorMpc
from rpod.scenarios.loader import load_scenario

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "los_corridor_mpc.md"
COMMAND = "python benchmarks/bench_los_corridor_mpc.py"


def record(scenario) -> tuple[list[tuple], object]:
    """Flies the scenario; returns the arguments of every MPC solve and the MPC settings."""
    calls = []
    original = LosCorridorMpc.solve

    def recording(self, x_k, x_ref, u_prev, A_d, B_d, u_nom=None):
        calls.append(
            tuple(np.array(v, dtype=float, copy=True) for v in (x_k, x_ref, u_prev, A_d, B_d))
            + (None if u_nom is None else np.array(u_nom, dtype=float),)
        )
        return original(self, x_k, x_ref, u_prev, A_d, B_d, u_nom)

    los_corridor_mpc.LosCorridorMpc.solve = recording
    try:
        summary = simulate(scenario).summary
    finally:
        los_corridor_mpc.LosCorridorMpc.solve = original
    return calls, summary


def replay(calls, settings, corridor) -> dict:
    """Per-step times [s] of ours and of raw OSQP on the same QPs, and ours' iterations."""
    mpc = LosCorridorMpc(settings, corridor.A_c, corridor.b_c)
    P, q, A, l, u = mpc.qp(*calls[0][:5], u_nom=calls[0][5])
    raw = osqp.OSQP()
    raw.setup(
        P=P,
        q=q,
        A=A,
        l=l,
        u=u,
        eps_abs=settings.eps_abs,
        eps_rel=settings.eps_rel,
        max_iter=settings.max_iter,
        polishing=settings.polishing,
        warm_starting=True,
        verbose=False,
    )
    ours, reference, iterations, raw_iterations, usable = [], [], [], [], []
    for x_k, x_ref, u_prev, A_d, B_d, u_nom in calls:
        _, q, A, l, u = mpc.qp(x_k, x_ref, u_prev, A_d, B_d, u_nom=u_nom)  # untimed
        Ax = A.data[mpc._dyn_csc_slots]
        start = time.perf_counter()
        raw.update(q=q, l=l, u=u, Ax=Ax, Ax_idx=mpc._dyn_csc_slots)
        raw_result = raw.solve(raise_error=False)
        reference.append(time.perf_counter() - start)
        raw_iterations.append(raw_result.info.iter)
        result = mpc.solve(x_k, x_ref, u_prev, A_d, B_d, u_nom=u_nom)
        ours.append(result.solve_time_s)
        iterations.append(result.iterations)
        usable.append(result.solved)
    return {
        "ours": 1e3 * np.array(ours),
        "raw": 1e3 * np.array(reference),
        "iterations": np.array(iterations),
        "raw_iterations": np.array(raw_iterations),
        "usable": np.array(usable),
    }


def cases():
    """(name, scenario) of each row."""
    _, single = load_scenario("los_corridor")
    _, mc = load_scenario("los_corridor")
    mc.duration_s = 400.0
    mc.controller = dataclasses.replace(
        mc.controller,
        mpc=dataclasses.replace(mc.controller.mpc, horizon=20, R_du_diag=[1e5, 1e4, 1e5]),
    )
    return [
        ("single scenario: N_p = 40, R_du = 1e4 I, 600 s", single),
        ("Monte Carlo: N_p = 20, R_du = diag(1e5, 1e4, 1e5), 400 s", mc),
    ]


def main() -> None:
    load = os.getloadavg()
    rows = []
    for name, scenario in cases():
        calls, summary = record(scenario)
        config = scenario.controller
        m = replay(calls, config.mpc_settings(), config.corridor())
        ours, raw = m["ours"], m["raw"]
        slow = int(np.count_nonzero(ours > 3.0))
        rows.append(
            f"| {name} | {len(calls)} | {np.median(ours):.3f} | {np.percentile(ours, 99):.3f} | "
            f"{ours.max():.1f} | {slow} | {np.median(raw):.3f} | {np.percentile(raw, 99):.3f} | "
            f"{np.median(ours / raw):.2f} | {np.sum(ours) / np.sum(raw):.2f} | "
            f"{np.median(m['iterations']):.0f} / {np.percentile(m['iterations'], 99):.0f} | "
            f"{np.count_nonzero(~m['usable'])} | {summary['mission']['outcome']} |"
        )
        print(rows[-1], file=sys.stderr, flush=True)
    lines = [
        "# Paper 004's MPC: per-step time against raw OSQP on the identical QPs",
        "",
        (
            f"Machine: {machine_line()}, osqp {osqp.__version__}; `{COMMAND}`; 1-minute load "
            f"average {load[0]:.2f} at the start."
        ),
        "",
        (
            "The QPs of a real closed loop (los_corridor on J2 truth, the exact Jacobian as the "
            "model: A_d, B_d new every step), recorded, then replayed into "
            "`LosCorridorMpc.solve` and into a raw OSQP problem of the identical QP fed the same "
            "data through its own update path (q, l, u and the A_d, B_d values; a warm solve). "
            "Goal: at most 1.5x raw, p99 under 3 ms."
        ),
        "",
        (
            "| case | steps | ours median (ms) | ours p99 (ms) | ours max (ms) | steps over "
            "3 ms | raw median (ms) | raw p99 (ms) | median ratio | total ratio | ADMM "
            "iterations median / p99 | steps without a usable input | closed-loop outcome |"
        ),
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
        *rows,
        "",
        (
            "Where the two differ most, ours is the faster: its warm start is the previous "
            "solution shifted one step along the horizon (the receding horizon's own guess), raw "
            "OSQP's the previous solution as it was; on the first steps of the approach from "
            "100 m, where the inputs sit on the box (the centripetal omega_t^2 r = 0.12 m/s^2 "
            "exceeds a_max there), raw OSQP runs to its iteration limit and ours does not. The "
            "slowest steps are the first two, cold."
        ),
    ]
    write_results(RESULTS, lines)


if __name__ == "__main__":
    main()
