"""An independent reference for the translational truth: two-body + J2 in ECI, written out here.

Test-only reference (tests/reference, not part of the rpod package). Owns: the point-mass + J2
gravity differentiated by hand, the LVLH frame and the circular orbit built here, and
`eci_reference`, which integrates both bodies absolutely in ECI with scipy's DOP853 at rtol 1e-13
(tests/reference/test_orbital_dynamics.py and tests/systems/test_truth.py hold the truth to it).
Does not own: anything of rpod.models (it uses only its constants), on purpose.
"""

import math

import numpy as np
from scipy.integrate import solve_ivp

from rpod.models.gravity import J2_EARTH, MU_EARTH_M3_S2, R_EARTH_M

DEG = math.pi / 180.0


def gravity_reference(p, with_j2=True):
    """-mu p / r^3 plus J2 = -grad of mu J2 R^2 / r^3 P2(z/r), differentiated by hand."""
    r2 = p @ p
    r = math.sqrt(r2)
    a = -MU_EARTH_M3_S2 / (r2 * r) * p
    if with_j2:
        c = 1.5 * J2_EARTH * MU_EARTH_M3_S2 * R_EARTH_M**2 / r**5
        w = 5.0 * p[2] ** 2 / r2
        a = a + c * np.array([p[0] * (w - 1.0), p[1] * (w - 1.0), p[2] * (w - 3.0)])
    return a


def lvlh_reference(p, v, a):
    """R_IL (x radial, z along p x v) and w_IL_L = [r a_n / h, 0, h / r^2]."""
    h_vec = np.cross(p, v)
    x = p / np.linalg.norm(p)
    z = h_vec / np.linalg.norm(h_vec)
    R_IL = np.column_stack([x, np.cross(z, x), z])
    h = np.linalg.norm(h_vec)
    r = np.linalg.norm(p)
    return R_IL, np.array([r * (a @ z) / h, 0.0, h / r**2])


def circular_state_reference(altitude, inclination, raan, u):
    """Rotate a circle in the x-y plane: Rz(raan) Rx(inclination) Rz(u) applied to [r, 0, 0]."""

    def Rz(t):
        return np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])

    def Rx(t):
        return np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])

    r = R_EARTH_M + altitude
    M = Rz(raan) @ Rx(inclination) @ Rz(u)
    return M @ [r, 0.0, 0.0], M @ [0.0, math.sqrt(MU_EARTH_M3_S2 / r), 0.0]


def eci_reference(orbit, p_LC_L0, v_LC_L0, times, f_L=None, m0=1.0, mass_flow=0.0, with_j2=True):
    """Both bodies integrated absolutely in ECI with DOP853; returns p_LC_L, v_LC_L at `times`.

    The force f_L (default zero) is held constant in the target's LVLH frame, the mass is
    m0 - mass_flow t.
    """
    f_L = np.zeros(3) if f_L is None else f_L
    p_T, v_T = circular_state_reference(
        orbit.altitude_m,
        orbit.inclination_deg * DEG,
        orbit.raan_deg * DEG,
        orbit.arg_latitude_deg * DEG,
    )
    R_IL, w = lvlh_reference(p_T, v_T, gravity_reference(p_T, with_j2))
    p_C = p_T + R_IL @ p_LC_L0
    v_C = v_T + R_IL @ (v_LC_L0 + np.cross(w, p_LC_L0))

    def rhs(t, x):
        R = lvlh_reference(x[0:3], x[3:6], np.zeros(3))[0]
        f_I = R @ f_L / (m0 - mass_flow * t)
        return np.concatenate(
            [
                x[3:6],
                gravity_reference(x[0:3], with_j2),
                x[9:12],
                gravity_reference(x[6:9], with_j2) + f_I,
            ]
        )

    sol = solve_ivp(
        rhs,
        (0.0, times[-1]),
        np.concatenate([p_T, v_T, p_C, v_C]),
        method="DOP853",
        rtol=1e-13,
        atol=1e-9,
        t_eval=times,
    )
    assert sol.success
    out = []
    for x in sol.y.T:
        R_IL, w = lvlh_reference(x[0:3], x[3:6], gravity_reference(x[0:3], with_j2))
        p_L = R_IL.T @ (x[6:9] - x[0:3])
        v_L = R_IL.T @ (x[9:12] - x[3:6]) - np.cross(w, p_L)
        out.append(np.concatenate([p_L, v_L]))
    return np.array(out)
