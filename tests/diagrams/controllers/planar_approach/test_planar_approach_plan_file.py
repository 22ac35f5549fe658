"""`rpod plan` of paper 003's approach (plan_file.py through rpod.scenarios.plan's writer): the
plan file holds what the planner planned, and the checker's verdict decides `passed`."""

import json

import numpy as np

from rpod.diagrams.controllers.planar_approach.planning import plan_scenario
from rpod.scenarios.loader import load_scenario
from rpod.scenarios.plan import plan_to_folder


def test_the_planar_plan_is_written_through_the_common_writer(tmp_path):
    name, scenario = load_scenario("planar_approach")
    # Only the candidate the bundled scenario picks (86.4 s): which candidates are tried is the
    # planner's business (tests/planners/test_planar_approach_planner.py), not the writer's.
    scenario.controller.planner.duration_min_s = 80.0
    scenario.controller.planner.max_duration_candidates = 1
    summary = plan_to_folder(name, scenario, tmp_path / "p")
    _, x0, plan, check = plan_scenario(scenario)
    assert (summary["status"], summary["passed"]) == ("success", True) and check["passed"]
    assert summary["duration_s"] == plan.duration_s
    assert json.loads((tmp_path / "p" / "summary.json").read_text()) == summary
    arrays = np.load(tmp_path / "p" / "plan.npz")
    np.testing.assert_array_equal(arrays["x"], plan.x_knots)
    np.testing.assert_array_equal(arrays["wrench"], plan.wrench_knots)
    np.testing.assert_array_equal(arrays["x0"], x0)
    assert arrays["t"][-1] == plan.duration_s
    assert summary["plots"] == ["plan_path.png"]
    assert (tmp_path / "p" / "plots" / "plan_path.png").stat().st_size > 10_000
