"""The chaser's thrust enters the navigation as its IMU's increments over an interval, mapped
into the rotating LVLH frame (rpod.systems.navigation.NavigationComputer._thrust_since):
checked against an independent integration of the two orbits (scipy, two-body + J2, 1e-12)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rpod.models.gravity import circular_orbit_state, gravity_acceleration
from rpod.models.orbit import lvlh_of
from rpod.systems.navigation import NavigationComputer, NavigationMemory
from rpod.systems.navigation_config import Ekf

GRAVITY = "two_body_j2"


def _fly(state_I, t_s):
    """A coasting spacecraft's orbit after t_s."""

    def rates(_, x):
        return np.concatenate([x[3:], gravity_acceleration(x[:3], GRAVITY)])

    return solve_ivp(rates, (0.0, t_s), state_I, method="DOP853", rtol=1e-13, atol=1e-9).y[:, -1]


def _thrust_effect_I(chaser_I, t_s, a_I):
    """(dp_I, dv_I): what the constant acceleration a_I adds to the chaser's orbit after t_s,
    integrated as a difference from the coasting orbit (the difference of two orbits of
    7,000 km would lose it to round-off)."""

    def rates(_, x):
        p, d = x[:3], x[6:9]
        g = gravity_acceleration(p, GRAVITY)
        return np.concatenate([x[3:6], g, x[9:12], gravity_acceleration(p + d, GRAVITY) - g + a_I])

    x0 = np.concatenate([chaser_I, np.zeros(6)])
    x = solve_ivp(rates, (0.0, t_s), x0, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
    return x[6:9], x[9:12]


@pytest.mark.parametrize("dt_s", [0.1, 0.5])
def test_the_thrust_s_increments_are_what_it_adds_to_the_relative_state_in_l(dt_s):
    p_IT, v_IT = circular_orbit_state(500e3, np.radians(51.6), 0.5, 0.3)
    target = np.concatenate([p_IT, v_IT])
    R_IL, w_IL_L = lvlh_of(p_IT, v_IT, GRAVITY)
    chaser = target + np.concatenate([R_IL @ [5.0, -30.0, 2.0], R_IL @ [0.01, 0.02, -0.01]])
    a_I = R_IL @ np.array([0.03, -0.05, 0.02])  # hold_point's approach: ~0.05 m/s^2

    computer = NavigationComputer(Ekf(), 0, 0.0011, GRAVITY, np.array([0.0, 0.0, 1.0]))
    memory = NavigationMemory(
        chaser_last=chaser,
        gravity_last=tuple(gravity_acceleration(chaser[:3], GRAVITY)),
        R_IL=R_IL,
        w_IL_L=w_IL_L,
    )
    dp_I, dv_I = _thrust_effect_I(chaser, dt_s, a_I)
    coasting = _fly(chaser, dt_s)
    dp_L, dv_L = computer._thrust_since(memory, coasting + np.concatenate([dp_I, dv_I]), dt_s)

    # What the thrust added to the relative state, in L at the end (v seen in L).
    target_1 = _fly(target, dt_s)
    R_IL_1, w_IL_L_1 = lvlh_of(target_1[:3], target_1[3:], GRAVITY)
    true_dp = R_IL_1.T @ dp_I
    true_dv = R_IL_1.T @ dv_I - np.cross(w_IL_L_1, true_dp)

    # Left out: second order in the frame's turn n dt (~5e-4 at 0.5 s), and the trapezoid's
    # error on gravity's curvature along the orbit, dt^3 n^4 r / 12 in velocity (1e-7 m/s at
    # 0.5 s) and dt^4 n^4 r / 24 in position. Without the first-order terms of the turn the
    # velocity was off by ~n dt |dv| (1.5e-5 m/s at 0.5 s), 100 times this bound. The position's
    # increment is a difference of positions 7,000 km from the Earth's centre: a few of their
    # round-offs (np.spacing(r) ~ 1e-9 m) are its floor.
    n, r = np.linalg.norm(w_IL_L), np.linalg.norm(p_IT)
    turn = n * dt_s
    curvature = n**4 * r
    np.testing.assert_allclose(
        dv_L,
        true_dv,
        rtol=0,
        atol=1e-3 * turn * np.linalg.norm(true_dv) + 1.5 * dt_s**3 * curvature / 12,
    )
    np.testing.assert_allclose(
        dp_L,
        true_dp,
        rtol=0,
        atol=1e-3 * turn * np.linalg.norm(true_dp) + dt_s**4 * curvature / 16 + 8 * np.spacing(r),
    )
