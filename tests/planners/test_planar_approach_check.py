"""The independent checker of paper 003's approach plans (rpod.planners.planar_approach_check):
its own teeth on the Sec. V-A plan made faulty (keep-out, wrench, eq. 7, the heading in State
II). The plan is the session's (tests/planners/conftest.py: sec_v_a, from this X0)."""

import dataclasses
import math

import numpy as np
from pydrake.trajectories import PiecewisePolynomial

from rpod.models import planar_approach as pa
from rpod.planners.planar_approach_check import check_plan

X0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # Sec. V-A: (1.0, 0.0) m, at rest


def test_the_checker_finds_violations(sec_v_a):
    config, plan = sec_v_a
    # Straight through the target: KOS entries; wrench scaled 100x: beyond the limits; and a
    # knot moved: an eq. 7 residual.
    X = plan.x_knots.copy()
    s = np.linspace(0.0, 1.0, len(X))[:, None]
    X[:, :2] = (1 - s) * X0[:2] + s * np.array([-1.0, 0.0])
    X[5, 0] += 0.01
    bad = dataclasses.replace(
        plan,
        x_traj=PiecewisePolynomial.FirstOrderHold(plan.t_knots, X.T),
        wrench_traj=PiecewisePolynomial.ZeroOrderHold(
            plan.t_knots, 100.0 * np.vstack([plan.wrench_knots, np.zeros(3)]).T
        ),
    )
    report = check_plan(bad, config)
    assert not report["passed"]
    assert report["keepout_violations"] > 0 and report["keepout_q_m"] < -0.3
    assert report["euler_residual"] > 1e-3
    assert report["force_excess_N"] > 0 or report["wrench_cut_excess_N"] > 0
    assert report["allocation_residual"] > 1e-3
    assert report["squares_gap_m"] < 0.0


def test_the_checker_wants_the_heading_on_the_face_in_state_ii(sec_v_a):
    # The same path with the heading turned 30 deg off from the plan's over the final
    # approach: the relaxed zone is not the chaser's any more (State I there, q < 0), and the
    # squares come within the 16 mm that an aligned chaser keeps.
    config, plan = sec_v_a
    X = plan.x_knots.copy()
    X[plan.keepout_state == pa.STATE_II, 2] += math.radians(30.0)
    turned = dataclasses.replace(plan, x_traj=PiecewisePolynomial.FirstOrderHold(plan.t_knots, X.T))
    report = check_plan(turned, config)
    assert not report["passed"]
    assert report["keepout_q_m"] < -0.05 and report["state_ii_fraction"] == 0.0
    assert report["squares_gap_m"] < check_plan(plan, config)["squares_gap_m"]
