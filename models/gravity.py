"""Earth gravity models (two-body and J2) and circular-orbit set-up.

Owns: the gravitational constants, the point-mass and J2 accelerations in ECI (frame I) and
their analytic gradient, the analytic secular J2 nodal-regression rate, and the circular orbit
state from orbital elements.
Does not own: integration (see rpod.systems.truth), the orbit set-up of a scenario
(rpod.models.orbit) or relative motion (rpod.models.cw).

Every function takes numpy arrays (float or AutoDiffXd object arrays) and returns numpy arrays,
except the float-only hot paths `gravity_acceleration_xyz` and `gravity_gradient`.
"""

from __future__ import annotations

import math

import numpy as np

MU_EARTH_M3_S2 = 3.986004418e14  # EGM96 / WGS-84 gravitational parameter.
R_EARTH_M = 6378137.0  # WGS-84 equatorial radius.
J2_EARTH = 1.08262668e-3  # EGM96 unnormalised J2.
MIN_ALTITUDE_M = 100e3  # Below the Karman line the vacuum two-body + J2 truth is meaningless.

GRAVITY_MODELS = ("two_body_j2", "two_body", "cw", "free_space")


def two_body_acceleration(p_I: np.ndarray, mu: float = MU_EARTH_M3_S2) -> np.ndarray:
    """Point-mass gravity a = -mu r / |r|^3 (paper 004 eq. 3, first term)."""
    r2 = p_I[0] * p_I[0] + p_I[1] * p_I[1] + p_I[2] * p_I[2]
    r = np.sqrt(r2) if isinstance(r2, float) else r2**0.5
    return (-mu / (r2 * r)) * p_I


def j2_acceleration(
    p_I: np.ndarray, mu: float = MU_EARTH_M3_S2, r_earth: float = R_EARTH_M, j2: float = J2_EARTH
) -> np.ndarray:
    """J2 zonal-harmonic perturbation in ECI (paper 004 eq. 3, a_J2; Vallado eq. 8-30)."""
    x, y, z = p_I[0], p_I[1], p_I[2]
    r2 = x * x + y * y + z * z
    r = r2**0.5
    k = -1.5 * j2 * mu * r_earth * r_earth / (r2 * r2 * r)
    s = 5.0 * z * z / r2
    return np.array([k * x * (1.0 - s), k * y * (1.0 - s), k * z * (3.0 - s)])


def gravity_acceleration(p_I: np.ndarray, model: str) -> np.ndarray:
    """Gravitational acceleration at p_I for one of GRAVITY_MODELS ('cw' uses two-body here).

    The 'cw' model is a relative-motion model; the target orbit under it is a two-body orbit.
    """
    if model == "two_body_j2":
        return two_body_acceleration(p_I) + j2_acceleration(p_I)
    if model in ("two_body", "cw"):
        return two_body_acceleration(p_I)
    if model == "free_space":
        return np.zeros(3)
    raise ValueError(f"unknown gravity model '{model}', expected one of {GRAVITY_MODELS}")


def gravity_acceleration_xyz(
    x: float, y: float, z: float, model: str
) -> tuple[float, float, float]:
    """Float-only gravity_acceleration on components, for simulation hot paths.

    Same equations as two_body_acceleration + j2_acceleration with plain Python floats, which is
    ~5x cheaper than numpy on 3-vectors; tests check that both agree to round-off.
    """
    if model == "free_space":
        return 0.0, 0.0, 0.0
    r2 = x * x + y * y + z * z
    r = math.sqrt(r2)
    k0 = -MU_EARTH_M3_S2 / (r2 * r)
    if model != "two_body_j2":
        return k0 * x, k0 * y, k0 * z
    k = -1.5 * J2_EARTH * MU_EARTH_M3_S2 * R_EARTH_M * R_EARTH_M / (r2 * r2 * r)
    s = 5.0 * z * z / r2
    kxy = k0 + k * (1.0 - s)
    return kxy * x, kxy * y, (k0 + k * (3.0 - s)) * z


def gravity_gradient(p_I: np.ndarray, model: str) -> np.ndarray:
    """G = d a / d p (3, 3) of `gravity_acceleration(p_I, model)`, analytic, float only.

    With u = p / r, s = 5 u_z^2 and k = -3/2 J2 mu R^2 / r^5 (the factor of `j2_acceleration`):

        two-body:  G = -mu / r^3 (I - 3 u u^T)
        J2:  G_J2 = k [diag(1 - s, 1 - s, 3 - s) + (7 s - 5) u u^T - 10 u_z (u e_z^T + e_z u^T)]

    G is symmetric (the Hessian of the potential). 'cw' is two-body here, as in
    `gravity_acceleration`; free space gives zeros.
    """
    if model == "free_space":
        return np.zeros((3, 3))
    if model not in GRAVITY_MODELS:
        raise ValueError(f"unknown gravity model '{model}', expected one of {GRAVITY_MODELS}")
    x, y, z = float(p_I[0]), float(p_I[1]), float(p_I[2])
    r2 = x * x + y * y + z * z
    r = math.sqrt(r2)
    u = np.array([x / r, y / r, z / r])
    uu = np.outer(u, u)
    G = (-MU_EARTH_M3_S2 / (r2 * r)) * (np.eye(3) - 3.0 * uu)  # d(-mu p / r^3) / dp
    if model == "two_body_j2":
        k = -1.5 * J2_EARTH * MU_EARTH_M3_S2 * R_EARTH_M * R_EARTH_M / (r2 * r2 * r)
        s = 5.0 * u[2] * u[2]
        G_j2 = (7.0 * s - 5.0) * uu
        G_j2[0, 0] += 1.0 - s
        G_j2[1, 1] += 1.0 - s
        G_j2[2, 2] += 3.0 - s
        G_j2[:, 2] -= 10.0 * u[2] * u  # d s / d z, on every row (column z)
        G_j2[2, :] -= 10.0 * u[2] * u  # the z row: d(3 / r^5) = -15, not -5, u / r^6
        G += k * G_j2
    return G


def mean_motion(semi_major_axis_m: float, mu: float = MU_EARTH_M3_S2) -> float:
    """Keplerian mean motion n = sqrt(mu / a^3) in rad/s."""
    return math.sqrt(mu / semi_major_axis_m**3)


def j2_nodal_regression_rate(
    semi_major_axis_m: float,
    eccentricity: float,
    inclination_rad: float,
    mu: float = MU_EARTH_M3_S2,
    r_earth: float = R_EARTH_M,
    j2: float = J2_EARTH,
) -> float:
    """Secular RAAN rate dOmega/dt = -3/2 n J2 (R/p)^2 cos i (Vallado eq. 9-41), rad/s."""
    p = semi_major_axis_m * (1.0 - eccentricity**2)
    n = mean_motion(semi_major_axis_m, mu)
    return -1.5 * n * j2 * (r_earth / p) ** 2 * math.cos(inclination_rad)


def circular_orbit_state(
    altitude_m: float,
    inclination_rad: float,
    raan_rad: float,
    arg_latitude_rad: float,
    mu: float = MU_EARTH_M3_S2,
    r_earth: float = R_EARTH_M,
) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity in ECI of a circular orbit given by its classical elements.

    Returns (p_I, v_I) with |p_I| = r_earth + altitude_m and |v_I| = sqrt(mu / |p_I|).
    """
    a = r_earth + altitude_m
    speed = math.sqrt(mu / a)
    cO, sO = math.cos(raan_rad), math.sin(raan_rad)
    ci, si = math.cos(inclination_rad), math.sin(inclination_rad)
    cu, su = math.cos(arg_latitude_rad), math.sin(arg_latitude_rad)
    # Perifocal-to-ECI rotation R3(-raan) R1(-i) R3(-u), applied to [1,0,0] and [0,1,0].
    radial = np.array([cO * cu - sO * su * ci, sO * cu + cO * su * ci, su * si])
    along = np.array([-cO * su - sO * cu * ci, -sO * su + cO * cu * ci, cu * si])
    return a * radial, speed * along


def raan_of(p_I: np.ndarray, v_I: np.ndarray) -> float:
    """Right ascension of the ascending node of the osculating orbit through (p_I, v_I)."""
    h = np.cross(p_I, v_I)
    return math.atan2(h[0], -h[1])
