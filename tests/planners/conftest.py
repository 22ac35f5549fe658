"""Fixtures shared by the planner tests: paper 003's Sec. V-A plan, made once per session (three
duration candidates of the SCP) and read by the planner's and the checker's tests alike. Tests
that change it work on copies (dataclasses.replace, x_knots.copy())."""

import numpy as np
import pytest

from rpod.planners.planar_approach import PlanarApproachConfig, plan_approach

SEC_V_A_X0 = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # Sec. V-A: (1.0, 0.0) m, at rest


@pytest.fixture(scope="session")
def sec_v_a():
    """Sec. V-A: theta_approach = 3 pi / 4, omega = 0.1 rad/s, 0.3 m target; a 0.3 m, 10 kg
    chaser with planar_8 thrusters of 0.3 N (the config's defaults); three candidates, from
    SEC_V_A_X0. Returns (config, plan)."""
    config = PlanarApproachConfig()
    return config, plan_approach(config, SEC_V_A_X0.copy())
