"""The seam's one pattern for planning once at start (rpod.diagrams.controller_seam): each planner
plans in its system's initialization event from the sensed bundle at t = 0, and `rpod plan` makes
the same call on the truth's bundle, so on `!Truth` its plan is the closed loop's first, bit for
bit; on `!Ekf` the closed loop plans from the estimate, never from the scenario's truth.

Truths: the same IEEE operations give the same bits (np.array_equal, no tolerance); the
navigation's own output at t = 0, read independently of the planner.
"""

import dataclasses

import numpy as np
from pydrake.systems.analysis import Simulator

from rpod.diagrams.builder import build_diagram, sensed_at_start
from rpod.diagrams.controllers.planar_approach.planning import plan_scenario as plan_planar
from rpod.diagrams.controllers.planar_approach.plugin import flown_run
from rpod.diagrams.controllers.planar_approach.problem import PlanarStart, initial_planar_state
from rpod.diagrams.controllers.soft_capture.planning import plan_scenario as plan_soft_capture
from rpod.scenarios.loader import load_scenario
from rpod.systems.navigation_config import Ekf
from rpod.systems.sensed import Sensed


def _initialized(scenario):
    """(diagram, handles, context) after Simulator.Initialize: every plan at start made."""
    diagram, handles = build_diagram(scenario)
    simulator = Simulator(diagram)
    simulator.Initialize()
    return diagram, handles, simulator.get_context()


def _planar(**navigation):
    _, scenario = load_scenario("planar_approach")
    # Only the candidate the bundled scenario picks: the candidate search is the planner's.
    scenario.controller.planner.duration_min_s = 80.0
    scenario.controller.planner.max_duration_candidates = 1
    return dataclasses.replace(scenario, **navigation)


def test_the_truth_bundle_at_start_is_the_scenarios_start():
    scenario = _planar()
    sensed = Sensed.from_vector(sensed_at_start(scenario))
    np.testing.assert_array_equal(
        PlanarStart.from_sensed(sensed).x0, initial_planar_state(scenario)
    )
    _, handles, context = _initialized(scenario)
    controller = handles.controller
    read = controller.GetInputPort("sensed").Eval(controller.GetMyContextFromRoot(context))
    np.testing.assert_array_equal(read, sensed.vector)


def test_rpod_plan_writes_the_truth_fed_soft_capture_first_plan_bit_for_bit():
    _, scenario = load_scenario("soft_capture")
    planned = plan_soft_capture(scenario, closed_loop=True).plan
    _, handles, context = _initialized(scenario)
    controller = handles.controller
    first = controller.plan_records(controller.GetMyContextFromRoot(context))[0]
    assert first["kind"] == "initial" and first["accepted"]
    np.testing.assert_array_equal(np.array(first["x"]), planned.x)
    np.testing.assert_array_equal(np.array(first["u"]), planned.u)


def test_rpod_plan_writes_the_truth_fed_planar_plan_bit_for_bit():
    scenario = _planar()
    _, x0, plan, _ = plan_planar(scenario)
    _, handles, context = _initialized(scenario)
    run = flown_run(handles.wiring, context)
    np.testing.assert_array_equal(run.x0, x0)
    np.testing.assert_array_equal(run.plan.x_knots, plan.x_knots)
    np.testing.assert_array_equal(run.plan.wrench_knots, plan.wrench_knots)
    path = handles.controller.GetOutputPort("planned_path").Eval(
        handles.controller.GetMyContextFromRoot(context)
    )
    assert path.index == 1
    np.testing.assert_array_equal(path.p_LC_L[:, :2], plan.x_knots[:, :2])


def test_on_the_estimate_the_planar_plan_starts_from_the_estimate():
    scenario = _planar(navigation=Ekf())
    _, handles, context = _initialized(scenario)
    estimate = handles.navigation.GetOutputPort("sensed").Eval(
        handles.navigation.GetMyContextFromRoot(context)
    )
    start = PlanarStart.from_sensed(Sensed.from_vector(estimate))
    run = flown_run(handles.wiring, context)
    np.testing.assert_array_equal(run.x0, start.x0)
    assert run.config.omega_target_rad_s == start.omega_target_rad_s
    assert run.config.theta_target0_rad == start.theta_target0_rad
    truth = initial_planar_state(scenario)
    assert 0.0 < np.max(np.abs(run.x0 - truth)) < 0.1  # an estimate: near, not equal
