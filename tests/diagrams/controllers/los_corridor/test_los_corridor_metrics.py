"""Tests of diagrams/controllers/los_corridor/metrics.py's count of the steps without a usable
input by the hard QP's status (what tells an infeasible QP from a solver failure in a
campaign)."""

import numpy as np

from rpod.diagrams.controllers.los_corridor.metrics import no_input_by_status
from rpod.planners.los_corridor_mpc import MpcStatus
from rpod.systems.los_guidance import MPC_STATUS_CODES, Fallback, Regime

SOLVED = MPC_STATUS_CODES[MpcStatus.SOLVED]
INFEASIBLE = MPC_STATUS_CODES[MpcStatus.PRIMAL_INFEASIBLE]
LIMIT = MPC_STATUS_CODES[MpcStatus.MAX_ITERATIONS]


def test_steps_without_an_input_are_counted_by_status_and_regime():
    codes = np.array([SOLVED, INFEASIBLE, INFEASIBLE, LIMIT, -1, INFEASIBLE, LIMIT, SOLVED])
    fallbacks = np.array(
        [
            Fallback.NONE,
            Fallback.PREVIOUS_PLAN,  # far, infeasible: counted
            Fallback.NOMINAL,  # far, infeasible, the far command: a fallback by design
            Fallback.BRAKE,  # close, iteration limit: counted
            Fallback.PREVIOUS_PLAN,  # close, hard QP skipped: counted
            Fallback.BEST_EFFORT,  # close, infeasible, the best-effort QP flew: not counted
            Fallback.PREVIOUS_PLAN,  # far, iteration limit: counted
            Fallback.NONE,
        ]
    )
    regimes = np.array([Regime.FAR] * 3 + [Regime.CLOSE] * 3 + [Regime.FAR, Regime.HOLD])
    counts = no_input_by_status(codes, fallbacks, regimes)
    assert counts["far_primal_infeasible"] == 1 and counts["far_max_iterations"] == 1
    assert counts["max_iterations"] == 1 and counts["skipped"] == 1
    assert sum(counts.values()) == 4  # = solver_failures: previous plan or brake
    assert set(counts) == {
        prefix + name
        for prefix in ("", "far_")
        for name in [*(status.value for status in MpcStatus), "skipped"]
    }
