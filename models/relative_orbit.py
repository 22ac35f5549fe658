"""The chaser's motion about the target in LVLH under full gravity, not CW's linearisation.

Owns: `TargetOrbit` (the target's orbit at an instant, with its LVLH frame) and
`relative_acceleration_L` / `relative_jacobian_L`, the exact relative acceleration seen in L
under two-body or two-body + J2 gravity and its Jacobian: the navigation filter's second
process model (rpod.models.relative_navigation), for separations or orbits where CW's error
matters.
Does not own: gravity (rpod.models.gravity), the LVLH frame (rpod.models.frames, .orbit).

With p, v the chaser's position and velocity relative to the target, in L and seen in L, and
w = w_IL_L, the transport theorem gives

    a_L = R_LI (g(p_IT_I + R_IL p) - g(p_IT_I)) - 2 w x v - w x (w x p) - w_dot x p

(paper 004 eq. 4 is its linearisation about p = 0 on a circular two-body orbit). w_dot is
zero on a circular two-body orbit; J2 turns the orbit plane at a varying rate (the x part of
w, ~1e-6 rad/s, changing at ~1e-9 rad/s^2 in low orbit: 3e-7 m/s^2 at 200 m, which the test
against the truth saw), so it is kept, from w at +-1 s along the orbit. The target's orbit is
held over one prediction (at most half a second: LVLH turns by 6e-4 rad meanwhile).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rpod.models.frames import cross, skew
from rpod.models.gravity import gravity_acceleration_xyz, gravity_gradient
from rpod.models.orbit import lvlh_of


@dataclasses.dataclass(frozen=True)
class TargetOrbit:
    """The target's orbit at an instant: p_IT_I, v_IT_I [m, m/s] under a gravity model, and
    its LVLH frame (R_IL, w_IL_L)."""

    p_IT_I: np.ndarray
    v_IT_I: np.ndarray
    gravity: str
    R_IL: np.ndarray = dataclasses.field(init=False, repr=False)
    w_IL_L: np.ndarray = dataclasses.field(init=False, repr=False)
    g_T: np.ndarray = dataclasses.field(init=False, repr=False)
    w_dot_IL_L: np.ndarray = dataclasses.field(init=False, repr=False)

    def __post_init__(self):
        p, v = np.asarray(self.p_IT_I, dtype=float), np.asarray(self.v_IT_I, dtype=float)
        R_IL, w_IL_L = lvlh_of(p, v, self.gravity)
        g_T = np.array(gravity_acceleration_xyz(*p.tolist(), self.gravity))
        # w at +-1 s along the orbit (second-order steps): its rate, to ~1e-15 rad/s^2.
        ahead = lvlh_of(p + v + 0.5 * g_T, v + g_T, self.gravity)[1]
        behind = lvlh_of(p - v + 0.5 * g_T, v - g_T, self.gravity)[1]
        object.__setattr__(self, "R_IL", R_IL)
        object.__setattr__(self, "w_IL_L", w_IL_L)
        object.__setattr__(self, "g_T", g_T)
        object.__setattr__(self, "w_dot_IL_L", 0.5 * (ahead - behind))


def relative_acceleration_L(orbit: TargetOrbit, p_L, v_L) -> np.ndarray:
    """a_L (3,): the chaser's acceleration relative to the target, in L and seen in L, with no
    thrust (module docstring)."""
    p_L, v_L = np.asarray(p_L, dtype=float), np.asarray(v_L, dtype=float)
    w = orbit.w_IL_L
    p_IC_I = orbit.p_IT_I + orbit.R_IL @ p_L
    g_C = np.array(gravity_acceleration_xyz(*p_IC_I.tolist(), orbit.gravity))
    return (
        orbit.R_IL.T @ (g_C - orbit.g_T)
        - 2.0 * cross(w, v_L)
        - cross(w, cross(w, p_L))
        - cross(orbit.w_dot_IL_L, p_L)
    )


def relative_jacobian_L(orbit: TargetOrbit, p_L) -> np.ndarray:
    """A (6, 6) of d[p; v]/dt = [v; a_L] about (p_L, any v): [[0, I], [R_LI G R_IL - [w]x^2 -
    [w_dot]x, -2 [w]x]], G the gravity gradient at the chaser."""
    W = skew(orbit.w_IL_L)
    p_IC_I = orbit.p_IT_I + orbit.R_IL @ np.asarray(p_L, dtype=float)
    G = gravity_gradient(p_IC_I, orbit.gravity)
    A = np.zeros((6, 6))
    A[0:3, 3:6] = np.eye(3)
    A[3:6, 0:3] = orbit.R_IL.T @ G @ orbit.R_IL - W @ W - skew(orbit.w_dot_IL_L)
    A[3:6, 3:6] = -2.0 * W
    return A
