"""`plan_to_folder` (what `rpod plan` writes): plan.npz keys and shapes, summary.json, plots, and
the independent checker passing on the plan *as written to the file*.

Independence: the checker is given the arrays read back from plan.npz, the polytopes rebuilt
from the file's (A, b), and a target prediction recomputed here from the scenario's initial
state (not the one the planner used), so a plan written with the wrong attitudes, rates, hulls
or dynamics fails it.
"""

import dataclasses
import json
import math
import types

import numpy as np
import pytest

from rpod.diagrams.controllers.soft_capture import planner_config
from rpod.diagrams.scenario import target_rotation_in_lvlh
from rpod.models.frames import quaternion_wxyz
from rpod.models.shapes import ConvexPolytope
from rpod.planners.plan_check import check_plan
from rpod.planners.soft_capture import predict_for_planner
from rpod.scenarios.loader import ScenarioFileError, load_scenario
from rpod.scenarios.plan import plan_to_folder

TABLE_I = {  # paper 000 Table I, under the symbols plan.npz uses
    "m": 1500.0, "dt": 1.0, "U_max": 100.0, "v_max": 1.5, "omega_max": 0.2, "eps_p": 0.35,
    "eps_v": 0.03, "theta_dock": math.radians(30.0), "N_dock": 5, "gamma": 5.0, "psi": 750.0,
    "r_max": 100.0, "alpha_min": 1.3, "i_max": 15,
}  # fmt: skip


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    name, scenario = load_scenario("soft_capture")
    out = tmp_path_factory.mktemp("plan") / "soft_capture"
    summary = plan_to_folder(name, scenario, out)
    return scenario, out, summary


def test_plan_npz_has_every_array_with_its_shape(planned):
    _, out, summary = planned
    plan = np.load(out / "plan.npz")
    N = summary["N"]
    assert N >= 2
    shapes = {"t": (N,), "x": (N, 6), "u": (N - 1, 3), "q_LT": (N, 4), "w_IT_T": (N, 3),
              "q_LC": (N, 4), "alpha": (N,), "alpha_check": (N,), "A_chaser": (8, 3),
              "b_chaser": (8,), "A_target": (7, 3), "b_target": (7,), "D_c": (3,), "D_t": (3,)}  # fmt: skip
    for key, shape in shapes.items():
        assert plan[key].shape == shape, key
    for symbol, value in TABLE_I.items():
        assert float(plan[symbol]) == pytest.approx(value, rel=1e-12), symbol
    assert float(plan["n"]) == pytest.approx(math.sqrt(3.986004418e14 / 7738e3**3), rel=1e-9)
    np.testing.assert_array_equal(plan["D_c"], [0.0, 0.0, 2.7])
    np.testing.assert_array_equal(plan["D_t"], [0.0, 0.0, 2.7])
    np.testing.assert_allclose(plan["t"], np.arange(N) * 1.0)
    # The plan starts from the scenario's state.
    _, scenario = load_scenario("soft_capture")
    np.testing.assert_allclose(plan["x"][0], np.r_[scenario.chaser.p_LC_L, scenario.chaser.v_LC_L],
                               atol=1e-9)  # fmt: skip


def test_summary_has_the_planner_report_and_the_checker_report(planned):
    _, out, summary = planned
    on_disk = json.loads((out / "summary.json").read_text())
    assert on_disk == json.loads(json.dumps(summary))
    for key in ("status", "N", "scp_iterations", "solve_time_s", "cost", "min_alpha", "check",
                "attempts", "plots"):  # fmt: skip
        assert key in on_disk, key
    assert on_disk["status"] == "success"
    assert len(on_disk["solve_time_s"]) == on_disk["scp_iterations"] + 1  # Problem 2 first
    assert len(on_disk["step_time_s"]) == len(on_disk["solve_time_s"])
    assert on_disk["check"]["passed"] and not on_disk["check"]["violations"]
    assert on_disk["min_alpha"] > 1.0
    assert sorted(on_disk["plots"]) == ["alpha.png", "state.png", "thrust.png", "trajectory.png"]
    for name in on_disk["plots"]:
        assert (out / "plots" / name).stat().st_size > 10_000
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".")]  # no staging left


def test_the_independent_checker_passes_on_the_written_plan(planned):
    scenario, out, _ = planned
    arrays = np.load(out / "plan.npz")
    N = len(arrays["t"])
    plan = types.SimpleNamespace(
        N=N, **{key: arrays[key] for key in ("t", "x", "u", "q_LT", "w_IT_T", "q_LC", "alpha")}
    )
    config = planner_config(scenario)
    prediction = predict_for_planner(
        config,
        quaternion_wxyz(target_rotation_in_lvlh(scenario)),
        np.radians(scenario.target.w_IT_T_deg_s),
        np.asarray(scenario.target.inertia_kg_m2),
    )
    report = check_plan(
        plan, config, prediction,
        x0=np.r_[scenario.chaser.p_LC_L, scenario.chaser.v_LC_L],
        chaser_hull=ConvexPolytope.from_halfspaces(arrays["A_chaser"], arrays["b_chaser"]),
        target_hull=ConvexPolytope.from_halfspaces(arrays["A_target"], arrays["b_target"]),
    )  # fmt: skip
    assert report.passed(), report.violations()
    np.testing.assert_allclose(report.alpha_check, arrays["alpha_check"], rtol=0, atol=1e-9)


def test_closed_loop_plan_uses_the_tightened_tolerances(tmp_path):
    name, scenario = load_scenario("soft_capture")
    summary = plan_to_folder(name, scenario, tmp_path / "p", closed_loop=True)
    fraction = scenario.controller.plan_tolerance_fraction
    assert summary["eps_p"] == pytest.approx(0.35 * fraction)
    assert summary["check"]["passed"]
    assert float(np.load(tmp_path / "p" / "plan.npz")["eps_p"]) == pytest.approx(0.35 * fraction)


def test_a_scenario_without_a_soft_capture_controller_is_refused(tmp_path):
    name, scenario = load_scenario("hold_point")
    with pytest.raises(ScenarioFileError, match="needs a controller with a planner"):
        plan_to_folder(name, scenario, tmp_path / "p")
    assert not (tmp_path / "p").exists()


def test_a_failed_plan_is_written_with_its_status(tmp_path):
    """A tumble above the method's limit: status and reason, empty arrays, no plots, no check."""
    name, scenario = load_scenario("soft_capture")
    scenario = dataclasses.replace(
        scenario, target=dataclasses.replace(scenario.target, w_IT_T_deg_s=[15.0, 0.0, 0.0])
    )
    summary = plan_to_folder(name, scenario, tmp_path / "p")
    assert summary["status"] == "tumble_rate_above_limit" and summary["N"] == 0
    assert summary["check"] is None and summary["plots"] == []
    plan = np.load(tmp_path / "p" / "plan.npz")
    assert plan["x"].shape == (0, 6) and plan["u"].shape == (0, 3)
