"""The `!LosCorridor` plug-in: its fields are checked by name, its actuation follows the config,
and a start given at rest in the target frame is at rest there (eq. 8)."""

import dataclasses

import numpy as np
import pytest

from rpod.diagrams.controller_seam import Actuation, plugin_for
from rpod.diagrams.controllers.los_corridor import LosCorridor
from rpod.diagrams.scenario import ScenarioError, initial_relative_state_L, validate_scenario
from rpod.models.frames import rotation_from_rpy_deg
from rpod.scenarios.loader import load_scenario


def _scenario(**controller):
    scenario = load_scenario("los_corridor")[1]
    scenario.controller = dataclasses.replace(scenario.controller, **controller)
    return scenario


@pytest.mark.parametrize(
    "change, field",
    [
        ({"prediction": "exact"}, "controller.prediction"),
        ({"a_max_m_s2": 0.0}, "controller.a_max_m_s2"),
        ({"hold_distance_m": 0.5}, "controller.hold_distance_m"),  # below the 1 m floor
        ({"actuation": "rockets"}, "controller.actuation"),
        ({"faces": 2}, "controller.faces"),
    ],
)
def test_bad_fields_are_named(change, field):
    with pytest.raises(ScenarioError, match=field.replace(".", r"\.")):
        validate_scenario(_scenario(**change))


def test_a_second_bound_in_the_mpc_block_is_refused():
    scenario = _scenario()
    scenario.controller.mpc.a_max_m_s2 = 0.3
    with pytest.raises(ScenarioError, match=r"controller\.mpc\.a_max_m_s2"):
        validate_scenario(scenario)


def test_the_linearisation_needs_an_orbit():
    scenario = _scenario()
    scenario.orbit.gravity = "cw"
    with pytest.raises(ScenarioError, match=r"orbit\.gravity"):
        validate_scenario(scenario)


def test_a_hold_point_the_box_cannot_hold_is_a_warning_that_offers_one_it_can():
    """omega_t^2 |p_TH| > a_max (5 deg/s, 0.05 m/s^2 and the 10 m hold): warned at load, with
    the hold distance of the holding condition's margin (r_sync / 4 = 3.28 m)."""
    scenario = _scenario(a_max_m_s2=0.05)
    scenario.target.w_IT_T_deg_s = [0.0, 0.0, 5.0]
    plugin = plugin_for(scenario.controller)
    (warning,) = plugin.load_warnings(scenario.controller, scenario)
    assert warning.startswith("controller.hold_distance_m: the hold point 10 m")
    assert "r_sync / 2 = 6.57 m" in warning and "hold_distance_m = 3.28" in warning
    scenario.controller.hold_distance_m = 3.28
    assert plugin.load_warnings(scenario.controller, scenario) == []
    # The bundled scenario (2 deg/s, 0.10 m/s^2: r_hold 82 m) holds its 10 m: no warning.
    bundled = _scenario()
    assert plugin.load_warnings(bundled.controller, bundled) == []
    # Fast enough that nothing beyond the 1 m floor holds: said so.
    scenario.target.w_IT_T_deg_s = [0.0, 0.0, 20.0]
    (warning,) = plugin.load_warnings(scenario.controller, scenario)
    assert "no point beyond the corridor's 1 m floor can be held" in warning


def test_actuation_follows_the_config():
    plugin = plugin_for(LosCorridor())
    assert plugin.actuation_for(LosCorridor()) is Actuation.IDEAL
    assert plugin.actuation_for(LosCorridor(actuation="thrusters")) is Actuation.BODY_WRENCH


def test_a_start_seen_in_T_is_at_rest_in_the_turning_target_frame():
    scenario = load_scenario("los_corridor")[1]
    scenario.target.rpy_LT_deg = [10.0, -20.0, 35.0]
    p_L, v_L = initial_relative_state_L(scenario)
    from rpod.models.orbit import initial_orbit_state, lvlh_of

    w_IL_L = lvlh_of(*initial_orbit_state(scenario.orbit), scenario.orbit.gravity)[1]
    R_LT = rotation_from_rpy_deg(scenario.target.rpy_LT_deg)
    w_LT_L = R_LT @ np.radians(scenario.target.w_IT_T_deg_s) - w_IL_L
    # Seen in T (transport theorem from L): v_L - w_LT x p_L = 0.
    np.testing.assert_allclose(v_L - np.cross(w_LT_L, p_L), 0.0, atol=1e-15)
    scenario.chaser.velocity_seen_in = "L"
    np.testing.assert_array_equal(initial_relative_state_L(scenario)[1], 0.0)


def test_table3_rows_pair_the_starts_and_sit_beside_the_paper():
    from rpod.diagrams.controllers.los_corridor import table3_rows

    def row(spin, a_max, inside, held, depth, r_min, separation=5.0):
        return {
            "status": "ok",
            "overrides": {"target.w_IT_T_deg_s": [0.0, 0.0, spin], "controller.a_max_m_s2": a_max},
            "metrics": {
                "los_sync_range_m": 1.0,
                "los_start_inside_sync_range": inside,
                "los_held": held,
                "los_violation_depth_m": depth,
                "los_min_range_m": r_min,
                "min_separation_m": separation,
            },
        }

    rows = [
        row(2.0, 0.10, True, True, 0.0, 9.7),
        row(2.0, 0.10, False, False, 550.2, 159.4, separation=0.0),
        {"status": "ok", "overrides": {}, "metrics": {"final_range_m": 3.0}},  # not a LOS run
    ]
    (line,) = table3_rows(rows)
    assert line[:3] == ["2", "0.10", "164.1"]  # r_sync = 2 a_max / omega_t^2, exact
    assert line[3] == "82.1"  # r_hold = r_sync / 2, the holding condition
    assert line[4] == "hold, 0 violations, r_min 9.7 m"
    assert line[5] == "no hold, violated 550.20 m, r_min 159.4 m, CONTACT"
    assert line[6] == "164.1 / No / 143.0"  # the paper's row as printed
    assert table3_rows([rows[2]]) is None


def _mc_row(x, y, feasible, **extra_overrides):
    """One finished Monte Carlo run at 2 deg/s and 0.10 m/s^2, started at (x, y) in T."""
    overrides = {
        "target.w_IT_T_deg_s": [0.0, 0.0, 2.0],
        "controller.a_max_m_s2": 0.10,
        "chaser.p_LC_L": [x, y, 0.0],
        **extra_overrides,
    }
    return {
        "run_id": f"{x}-{y}-{sorted(extra_overrides)}",
        "status": "ok",
        "overrides": overrides,
        "metrics": {
            "sim_time_s": 400.0,
            "los_violation": not feasible,
            "los_violation_depth_m": 0.0 if feasible else 3.0,
            "stopped_early": None,
            "los_sync_range_m": 164.1,
            "los_start_inside_sync_range": True,
            "los_held": feasible,
            "los_min_range_m": 10.0,
            "min_separation_m": 5.0,
        },
    }


def test_a_monte_carlo_campaign_gets_the_sec_9_table_not_table_3():
    from rpod.diagrams.controllers.los_corridor import monte_carlo_rows, table3_rows

    row = _mc_row
    rows = [row(-5.0, 40.0, True), row(0.0, 60.0, True), row(5.0, 80.0, False), row(0, 100, False)]
    (line,) = monte_carlo_rows(rows)
    assert line[:3] == ["2", "0.10", "2/4"]
    assert line[4].endswith("(11.3)")  # paper 004 Table 2 beside ours
    assert monte_carlo_rows(rows[:2]) is None  # two starts: a Table 3 campaign
    assert table3_rows(rows[:2]) is not None


def test_a_campaign_of_two_controllers_on_the_same_starts_gets_one_block_each():
    """los_monte_carlo_paper flies rpod's MPC and the paper's on the same starts: one Monte
    Carlo each, labelled by the overrides that differ (mixed, the interpolation refused the
    repeated sites and `rpod report` died)."""
    from rpod.diagrams.controllers.los_corridor import LosCorridorPlugin

    starts = [(-5.0, 40.0, True), (0.0, 60.0, True), (5.0, 80.0, False), (0.0, 100.0, False)]
    rows = [_mc_row(*start) for start in starts]
    rows += [_mc_row(x, y, False, **{"controller.mpc.margin_m": 0.0}) for x, y, _ in starts]
    _, header, table = LosCorridorPlugin().campaign_table(rows)
    assert header[0] == "controller variant" and len(table) == 2
    assert table[0][:4] == ["defaults", "2", "0.10", "2/4"]
    assert table[1][:4] == ["mpc.margin_m=0.0", "2", "0.10", "0/4"]
