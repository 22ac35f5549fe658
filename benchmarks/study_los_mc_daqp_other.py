"""Do the Monte Carlo's DAQP exits other than 'solved' / 'infeasible' hide QPs with a solution?

    python benchmarks/study_los_mc_daqp_other.py runs/lmc_daqp [--part 0 --parts 2]

RESULTS is `rpod sweep benchmarks/campaigns/los_monte_carlo_daqp.yaml`. Every run whose summary
counts a step without a usable input under DAQP's 'other' exit (`los_no_input_by_status`) is
flown again in this process; each QP that DAQP ends with MpcStatus.OTHER (cycling, a singular
working set: no certificate either way) is rebuilt exactly as the controller built it
(`LosCorridorMpc.qp`) and solved by Clarabel's Python package, an interior point that
certifies infeasibility. Prints Clarabel's verdicts, counted, and every run with any verdict
but PrimalInfeasible. `--part i --parts n` takes every n-th run from the i-th (two processes
for two cores). Needs the bench extra (clarabel).
"""

import argparse
import pathlib

import numpy as np
from bench_los_corridor_mpc import clarabel_solution  # beside this script

from rpod.diagrams.simulate import simulate
from rpod.planners.los_corridor_mpc import LosCorridorMpc, MpcStatus
from rpod.scenarios.campaign import apply_overrides, load_campaign, plan_runs
from rpod.scenarios.report import read_results

CAMPAIGN = pathlib.Path(__file__).resolve().parent / "campaigns" / "los_monte_carlo_daqp.yaml"


def clarabel_status(mpc: LosCorridorMpc, args: tuple) -> str:
    """Clarabel's verdict on the QP mpc builds from one solve's arguments."""
    return str(clarabel_solution(mpc, args)[0].status)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", type=pathlib.Path)
    parser.add_argument("--part", type=int, default=0)
    parser.add_argument("--parts", type=int, default=1)
    args = parser.parse_args()
    campaign = load_campaign(str(CAMPAIGN))
    planned = {run.run_id: run for run in plan_runs(campaign)}
    _, rows = read_results(args.results)
    picked = [
        row
        for row in rows
        if row["status"] == "ok"
        and ((row["metrics"].get("los_no_input_by_status") or {}).get("far_other")
             or (row["metrics"].get("los_no_input_by_status") or {}).get("other"))
    ][args.part :: args.parts]  # fmt: skip
    original = LosCorridorMpc.solve
    verdicts: dict[str, int] = {}
    for row in picked:
        seen = []

        def checking(self, x_k, x_ref, u_prev, A_d, B_d, u_nom=None, seen=seen):
            result = original(self, x_k, x_ref, u_prev, A_d, B_d, u_nom)
            if result.status is MpcStatus.OTHER:
                copy = tuple(np.array(v, dtype=float) for v in (x_k, x_ref, u_prev, A_d, B_d))
                seen.append(clarabel_status(self, copy + (u_nom,)))
            return result

        LosCorridorMpc.solve = checking
        try:
            simulate(apply_overrides(campaign.base, planned[row["run_id"]].overrides))
        finally:
            LosCorridorMpc.solve = original
        for verdict in seen:
            verdicts[verdict] = verdicts.get(verdict, 0) + 1
        if any(verdict != "PrimalInfeasible" for verdict in seen):
            print(f"{row['run_id']} {row['case_name']}: {seen}", flush=True)
    print(f"{len(picked)} runs; Clarabel on the QPs DAQP ended as 'other': {verdicts}")


if __name__ == "__main__":
    main()
