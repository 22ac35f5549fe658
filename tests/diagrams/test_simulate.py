"""simulate(): contact of the true shapes as one event for every run, a recording that
leaves the physics exactly as it is, and a run that leaves no system behind."""

import dataclasses
import gc
import re

import numpy as np
import pytest
from pydrake.systems.framework import LeafSystem, System

from rpod.diagrams.controller_seam import (
    Actuation,
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
    IdealCommand,
    MissionOutcome,
    register_controller,
)
from rpod.diagrams.recording import make_headless_meshcat
from rpod.diagrams.scenario import Scenario
from rpod.diagrams.simulate import simulate
from rpod.scenarios.campaign import apply_overrides
from rpod.scenarios.loader import load_scenario
from rpod.systems.navigation_config import Ekf
from rpod.systems.sensed import SENSED_SIZE


class _Zero(LeafSystem):
    def __init__(self):
        super().__init__()
        self.DeclareVectorInputPort("sensed", SENSED_SIZE)
        self.DeclareVectorOutputPort("command", 3, lambda c, o: o.SetFromVector(np.zeros(3)))


@dataclasses.dataclass
class ClaimsSuccess:
    """Test controller: no thrust, and a mission outcome that always says success."""

    control_period_s: float = 1.0


class ClaimsSuccessPlugin(ControllerPlugin):
    config_type = ClaimsSuccess
    system_name = "claims_success"
    actuation = Actuation.IDEAL

    def add_to_diagram(self, builder, scenario, sensed):
        system = builder.AddNamedSystem(self.system_name, _Zero())
        builder.Connect(sensed, system.GetInputPort("sensed"))
        return ControllerWiring(system, system.GetOutputPort("command"), ideal=IdealCommand())

    def results(self, scenario, wiring, context, log):
        return ControllerResults(outcome=MissionOutcome(True, "the controller says success"))


register_controller(ClaimsSuccessPlugin())


def _fly_through(controller) -> Scenario:
    """A 1.5 m chaser cube coasting at 1 m/s through a 2 m target cube (free space): the
    faces meet at t = 18.25 s, the shapes overlap until 21.75 s, 1.75 m deep at 20 s."""
    _, base = load_scenario("coast")
    scenario = apply_overrides(
        base,
        {
            "orbit.gravity": "free_space",
            "chaser.p_LC_L": [0.0, -20.0, 0.0],
            "chaser.v_LC_L": [0.0, 1.0, 0.0],
            "chaser.point_at_target": False,
            "target.w_IT_T_deg_s": [0.0, 0.0, 0.0],
            "target.rpy_LT_deg": [0.0, 0.0, 0.0],
            "duration_s": 30.0,
            "log_period_s": 1.0,
        },
    )
    return dataclasses.replace(scenario, controller=controller)


def test_contact_is_found_between_log_samples_and_fails_a_claimed_success():
    result = simulate(_fly_through(ClaimsSuccess()))
    contact, mission = result.summary["contact"], result.summary["mission"]
    assert contact["occurred"] and contact["intervals"] == 1
    # Checked at every step end: the steps end at 1 s log samples and at the 1 s control
    # period here (an ideal path, no PWM), so the first contact is seen within one step.
    assert 18.25 <= contact["first_s"] <= 19.25 + 1e-9
    assert 20.75 - 1e-9 <= contact["last_s"] <= 21.75
    assert contact["max_depth_m"] == pytest.approx(1.75, abs=1e-9)
    assert contact["max_depth_t_s"] == pytest.approx(20.0)
    assert mission["controller_success"] is True and mission["success"] is False
    assert mission["outcome"].startswith("NOT a success: CONTACT of the true shapes from 19.00")
    assert "1750 mm deep" in mission["outcome"]
    assert mission["outcome"].endswith("the controller says success")
    # The log's penetration depth at the samples agrees.
    log = result.log
    assert log["penetration_m"][np.searchsorted(log["t"], 20.0)] == pytest.approx(1.75)
    assert np.all(log["penetration_m"][log["t"] < 18.0] == 0.0)


def test_contact_is_said_without_a_controller_and_absent_when_the_chaser_misses():
    result = simulate(_fly_through(None))
    assert result.summary["mission"]["success"] is None
    assert result.summary["mission"]["outcome"].startswith("CONTACT of the true shapes")
    missing = dataclasses.replace(_fly_through(ClaimsSuccess()))
    missing.chaser.p_LC_L = [5.0, -20.0, 0.0]  # passes 5 m to the side: 3.25 m of clearance
    result = simulate(missing)
    assert not result.summary["contact"]["occurred"]
    assert result.summary["contact"]["checks"] >= 30
    assert result.summary["mission"]["success"] is True


WALL_CLOCK = re.compile(r"(solve|wall|check|step)_time")

# One case of each method, drawn with a scene period that is not a multiple of the log period
# (the adversarial case: the old periodic scene events added steps there).
RECORDING_CASES = {
    "hold_point": {"duration_s": 40.0, "visualization.publish_period_s": 0.3},
    "soft_capture": {"duration_s": 20.0, "visualization.publish_period_s": 0.25},
    "los_corridor": {
        "duration_s": 60.0,
        "log_period_s": 1.0,
        "visualization.publish_period_s": 0.5,
        "controller.mpc.horizon": 20,
    },
    "asteroid_grasp": {"duration_s": 240.0, "visualization.publish_period_s": 7.0},
    # Only the candidate the bundled scenario picks (86.4 s) is planned: the other two cost
    # ~2/3 of each run's time, and which plan is flown does not change what a recording may do.
    "planar_approach": {
        "duration_s": 8.0,
        "visualization.publish_period_s": 0.25,
        "controller.planner.duration_min_s": 80.0,
        "controller.planner.max_duration_candidates": 1,
    },
}


# By default three methods (the scene's events are the same code for all); the other two slow.
RECORDING_SLOW = {"asteroid_grasp", "planar_approach"}


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(name, marks=pytest.mark.slow) if name in RECORDING_SLOW else name
        for name in sorted(RECORDING_CASES)
    ],
)
def test_a_recording_leaves_the_log_bit_identical(name):
    _, base = load_scenario(name)
    scenario = apply_overrides(base, RECORDING_CASES[name])
    if hasattr(scenario.stop, "at_plan_end"):
        scenario.stop.at_plan_end = False
    plain = simulate(scenario)
    drawn = simulate(scenario, make_headless_meshcat())
    assert plain.summary["integrator_steps"] == drawn.summary["integrator_steps"]
    assert sorted(plain.log) == sorted(drawn.log)
    for key in plain.log:
        if WALL_CLOCK.search(key):
            continue  # a solver's wall time, not physics
        np.testing.assert_array_equal(plain.log[key], drawn.log[key], err_msg=key)


def test_thruster_duty_is_logged_only_where_thrusters_fly():
    """duty.png showed every thruster at zero on the ideal and gimbaled paths: an ideal
    actuator has no duty to log (none, not zeros), and a gimbaled thruster's throttle is its
    force's magnitude over its largest."""
    _, ideal = load_scenario("los_corridor")
    ideal = apply_overrides(ideal, {"duration_s": 5.0, "controller.mpc.horizon": 10})
    assert "thruster_duty" not in simulate(ideal).log
    _, gimbaled = load_scenario("asteroid_grasp")
    log = simulate(apply_overrides(gimbaled, {"duration_s": 30.0})).log
    forces = log["thruster_force_C"].reshape(len(log["t"]), -1, 3)
    expected = np.linalg.norm(forces, axis=2) / 20.0  # the bundled bank: 8 x 20 N
    np.testing.assert_allclose(log["thruster_duty"], expected, rtol=1e-12)
    assert np.all(log["thruster_duty"] <= 1.0 + 1e-9) and np.any(log["thruster_duty"] > 0.01)


def _systems_alive() -> int:
    gc.collect()
    return sum(1 for item in gc.get_objects() if isinstance(item, System))


@pytest.mark.parametrize(
    "name, overrides, drawn",
    [
        ("hold_point", {"duration_s": 5.0, "navigation": Ekf()}, False),
        ("soft_capture", {"duration_s": 5.0}, True),
        ("los_corridor_thrusters", {"duration_s": 5.0}, False),
        ("asteroid_grasp", {"duration_s": 5.0}, False),
    ],
)
def test_a_run_leaves_no_system_behind(name, overrides, drawn):
    """simulate() frees its diagram and every system in it (rpod.systems.lifetime): a
    campaign's runner does thousands of runs in one process."""
    _, base = load_scenario(name)
    scenario = dataclasses.replace(base, **overrides)
    before = _systems_alive()
    simulate(scenario, make_headless_meshcat() if drawn else None)
    assert _systems_alive() == before
