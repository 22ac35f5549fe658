"""Tests for rpod.models.gravity against conservation laws, potentials and secular theory.

Independent truths used here:
- the two-body energy v^2/2 - mu/r and angular momentum p x v are integrals of motion;
- with J2 the force is conservative and axisymmetric, so v^2/2 + U and h_z are integrals too;
- each acceleration is minus the gradient of its potential energy (per unit mass), written out
  here from the Legendre expansion, not from the code under test;
- the secular nodal regression of Vallado eq. 9-41 (as the orbit integrated with the code's J2
  drifts, measured by a straight-line fit of its RAAN);
- the classical-element geometry of a circular orbit (inclination and RAAN from p x v).
"""

import math

import numpy as np
import pytest
from pydrake.autodiffutils import ExtractGradient, InitializeAutoDiff
from scipy.integrate import solve_ivp

from rpod.models.gravity import (
    J2_EARTH,
    MU_EARTH_M3_S2,
    R_EARTH_M,
    circular_orbit_state,
    gravity_acceleration,
    gravity_acceleration_xyz,
    gravity_gradient,
    j2_acceleration,
    j2_nodal_regression_rate,
    mean_motion,
    raan_of,
    two_body_acceleration,
)

MU = MU_EARTH_M3_S2
DEG = math.pi / 180.0


def _u_two_body(p):
    """Point-mass potential energy per unit mass, U = -mu / r (a = -grad U)."""
    return -MU / np.linalg.norm(p)


def _u_j2(p):
    """J2 potential energy per unit mass (a = -grad U).

    The geopotential is V = mu/r [1 - J2 (R/r)^2 P2(sin phi)] with a = +grad V, sin phi = z/r,
    P2(s) = (3 s^2 - 1)/2. The potential energy is U = -V, so its J2 part is
    U_J2 = +mu/r J2 (R/r)^2 P2(sin phi). (Sanity: on the equator P2 = -1/2, U_J2 < 0 and grows
    in magnitude inward, so the extra pull of the equatorial bulge points to the centre.)
    """
    r = np.linalg.norm(p)
    s = p[2] / r
    return MU / r * J2_EARTH * (R_EARTH_M / r) ** 2 * 0.5 * (3.0 * s * s - 1.0)


def _two_body_rhs(t, x):
    return np.concatenate([x[3:6], two_body_acceleration(x[0:3])])


def _j2_rhs(t, x):
    return np.concatenate([x[3:6], two_body_acceleration(x[0:3]) + j2_acceleration(x[0:3])])


def _periapsis_state(r_periapsis, e, inclination):
    """ECI state at periapsis of an orbit with periapsis on the x axis, node line along x."""
    speed = math.sqrt(MU * (1.0 + e) / r_periapsis)  # vis-viva at periapsis
    p = np.array([r_periapsis, 0.0, 0.0])
    v = speed * np.array([0.0, math.cos(inclination), math.sin(inclination)])
    return p, v


# (periapsis radius, eccentricity, inclination): circular LEO, Molniya-like, GTO-like.
ORBITS = [(6878e3, 0.0, 51.6 * DEG), (6678e3, 0.7, 63.4 * DEG), (6578e3, 0.73, 7.0 * DEG)]


@pytest.mark.parametrize("r_periapsis, e, inclination", ORBITS)
def test_two_body_conserves_energy_and_angular_momentum(r_periapsis, e, inclination):
    p0, v0 = _periapsis_state(r_periapsis, e, inclination)
    a = r_periapsis / (1.0 - e)
    period = 2.0 * math.pi / mean_motion(a)
    t_eval = np.linspace(0.0, 5.0 * period, 400)
    sol = solve_ivp(
        _two_body_rhs,
        (0.0, t_eval[-1]),
        np.concatenate([p0, v0]),
        method="DOP853",
        rtol=1e-12,
        atol=1e-6,
        t_eval=t_eval,
    )
    assert sol.success
    P, V = sol.y[0:3].T, sol.y[3:6].T
    energy = 0.5 * np.sum(V * V, axis=1) + np.array([_u_two_body(p) for p in P])
    h = np.cross(P, V)
    # Vis-viva: the orbit's energy is -mu / (2a); check the initial state is what we think.
    assert energy[0] == pytest.approx(-MU / (2.0 * a), rel=1e-14)
    # Tolerance 1e-8 relative: DOP853 at rtol 1e-12 takes ~1,000 steps per eccentric orbit, each
    # adding up to ~1e-12 of relative error; measured drifts are 2e-12 (circular) and 4e-10
    # (e = 0.7) over 5 orbits. A wrong exponent in -mu p / r^3 breaks energy at order 1.
    np.testing.assert_allclose(energy / energy[0], 1.0, rtol=0, atol=1e-8)
    np.testing.assert_allclose(
        (h - h[0]) / np.linalg.norm(h[0]), np.zeros_like(h), rtol=0, atol=1e-8
    )
    # And the orbit closes: after whole periods (2 pi sqrt(a^3/mu)) the body is back at
    # periapsis. 1e-7 a: measured 8e-12 a (circular) and 3e-9 a (eccentric, where the fast
    # periapsis passage turns a ~1e-10 energy error into an along-track miss).
    assert np.linalg.norm(P[-1] - p0) < 1e-7 * a


def test_two_body_plus_j2_conserves_energy_and_polar_angular_momentum():
    # J2 is conservative and symmetric about the z axis, so E = v^2/2 + U_2b + U_J2 and h_z are
    # integrals even though h_x, h_y precess. This checks the sign of the J2 force globally: with
    # the opposite sign E drifts at order J2 ~ 1e-3.
    p0, v0 = _periapsis_state(6678e3, 0.3, 63.0 * DEG)
    a = 6678e3 / 0.7
    period = 2.0 * math.pi / mean_motion(a)
    t_eval = np.linspace(0.0, 5.0 * period, 400)
    sol = solve_ivp(
        _j2_rhs,
        (0.0, t_eval[-1]),
        np.concatenate([p0, v0]),
        method="DOP853",
        rtol=1e-12,
        atol=1e-6,
        t_eval=t_eval,
    )
    assert sol.success
    P, V = sol.y[0:3].T, sol.y[3:6].T
    energy = 0.5 * np.sum(V * V, axis=1) + np.array([_u_two_body(p) + _u_j2(p) for p in P])
    h = np.cross(P, V)
    # Same 1e-8 integration budget as the two-body test (measured ~2e-11).
    np.testing.assert_allclose(energy / energy[0], 1.0, rtol=0, atol=1e-8)
    np.testing.assert_allclose(h[:, 2] / h[0, 2], 1.0, rtol=0, atol=1e-8)
    # The plane does precess (h_x, h_y change at order J2): the test above is not vacuous.
    assert np.abs(h[:, 0:2] - h[0, 0:2]).max() > 1e-4 * np.linalg.norm(h[0])


def _central_gradient(U, p, step):
    grad = np.zeros(3)
    for k in range(3):
        dp = np.zeros(3)
        dp[k] = step
        grad[k] = (U(p + dp) - U(p - dp)) / (2.0 * step)
    return grad


def _random_points(rng, count):
    """Points between 100 km altitude and beyond GEO, all latitudes including near the poles."""
    direction = rng.normal(size=(count, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    radius = rng.uniform(R_EARTH_M + 100e3, 4.5e7, size=count)
    points = direction * radius[:, None]
    points[0] = [0.0, 0.0, 7.0e6]  # on the pole
    points[1] = [7.0e6, 0.0, 0.0]  # on the equator
    return points


def test_j2_acceleration_is_minus_gradient_of_j2_potential():
    rng = np.random.default_rng(20240604)
    for p in _random_points(rng, 40):
        r = np.linalg.norm(p)
        a = j2_acceleration(p)
        a_fd = -_central_gradient(_u_j2, p, step=1e-6 * r)
        # Step 1e-6 r: truncation ~ (1e-6)^2 = 1e-12 relative; round-off ~ eps U / (step |grad U|)
        # ~ 1e-16 / 1e-6 = 1e-10 relative. Tolerance 1e-7 of the J2 magnitude at that radius
        # (a J2 factor-of-two or sign error is an O(1) miss).
        scale = 1.5 * J2_EARTH * MU * R_EARTH_M**2 / r**4
        np.testing.assert_allclose(a / scale, a_fd / scale, rtol=0, atol=1e-7)
    # The on-equator value is the textbook -3/2 J2 mu R^2 / r^4 radially (inward).
    r = 7.0e6
    np.testing.assert_allclose(
        j2_acceleration(np.array([r, 0.0, 0.0])),
        [-1.5 * J2_EARTH * MU * R_EARTH_M**2 / r**4, 0.0, 0.0],
        rtol=1e-14,
    )
    # At the pole P2 = 1: U_J2 = mu J2 R^2 / r^3 > 0 decreasing outward, a = +3 mu J2 R^2 / r^4
    # pointing away from the centre.
    np.testing.assert_allclose(
        j2_acceleration(np.array([0.0, 0.0, r])),
        [0.0, 0.0, 3.0 * J2_EARTH * MU * R_EARTH_M**2 / r**4],
        rtol=1e-14,
    )


def test_two_body_acceleration_is_minus_gradient_and_models_dispatch():
    rng = np.random.default_rng(7)
    for p in _random_points(rng, 20):
        r = np.linalg.norm(p)
        a_fd = -_central_gradient(_u_two_body, p, step=1e-6 * r)
        # Same step reasoning as the J2 test; 1e-8 relative to mu / r^2.
        np.testing.assert_allclose(two_body_acceleration(p), a_fd, rtol=0, atol=1e-8 * MU / r**2)
        np.testing.assert_allclose(
            gravity_acceleration(p, "two_body_j2"),
            two_body_acceleration(p) + j2_acceleration(p),
            rtol=1e-15,
        )
        np.testing.assert_array_equal(gravity_acceleration(p, "two_body"), two_body_acceleration(p))
        np.testing.assert_array_equal(gravity_acceleration(p, "cw"), two_body_acceleration(p))
        np.testing.assert_array_equal(gravity_acceleration(p, "free_space"), np.zeros(3))
    with pytest.raises(ValueError, match="unknown gravity model"):
        gravity_acceleration(np.array([7e6, 0.0, 0.0]), "j4")


@pytest.mark.parametrize("inclination_deg", [51.6, 98.0, 28.5])
def test_j2_nodal_regression_rate_matches_integrated_orbit(inclination_deg):
    inclination = inclination_deg * DEG
    altitude = 500e3
    a = R_EARTH_M + altitude
    p0, v0 = circular_orbit_state(altitude, inclination, 30.0 * DEG, 17.0 * DEG)
    n_orbits = 12
    period = 2.0 * math.pi / mean_motion(a)
    # 200 samples per orbit over a whole number of orbits: the short-periodic RAAN terms (at
    # twice the argument of latitude) average out of the straight-line fit.
    t_eval = np.linspace(0.0, n_orbits * period, n_orbits * 200 + 1)
    sol = solve_ivp(
        _j2_rhs,
        (0.0, t_eval[-1]),
        np.concatenate([p0, v0]),
        method="DOP853",
        rtol=1e-12,
        atol=1e-6,
        t_eval=t_eval,
    )
    assert sol.success
    raan = np.unwrap([raan_of(sol.y[0:3, k], sol.y[3:6, k]) for k in range(len(t_eval))])
    assert raan[0] == pytest.approx(30.0 * DEG, abs=1e-12)
    slope = np.polyfit(t_eval, raan, 1)[0]
    predicted = j2_nodal_regression_rate(a, 0.0, inclination)
    # Tolerance 1%. The formula is first-order secular theory in *mean* elements; we start from
    # osculating circular elements, whose semi-major axis and inclination differ from the mean
    # ones by O(J2 (R/a)^2) ~ 1e-3 (and the rate goes as a^-3.5 cos i), and second-order J2^2
    # terms are ~1e-6. Measured: 0.40% (51.6 deg), 0.41% (98 deg), 0.39% (28.5 deg). A wrong
    # power of (R/p), a missing 3/2 or a sign error (prograde orbits regress westward, sun-
    # synchronous 98 deg advances eastward) all miss by far more than 1%.
    assert np.sign(slope) == np.sign(predicted) == -np.sign(math.cos(inclination))
    assert slope == pytest.approx(predicted, rel=1e-2)


def test_sun_synchronous_rate_is_one_turn_per_year():
    # Published number: a sun-synchronous orbit advances 360 deg per tropical year. At 800 km
    # the sun-synchronous inclination is ~98.6 deg (Vallado, Table/eq. 9-42 examples; 98.60 deg
    # for the textbook J2 value). Solve cos i for the sun-synchronous rate and compare.
    a = R_EARTH_M + 800e3
    rate_ss = 2.0 * math.pi / (365.2422 * 86400.0)
    cos_i = rate_ss / j2_nodal_regression_rate(a, 0.0, 0.0)
    inclination_deg = math.degrees(math.acos(cos_i))
    # 0.05 deg: the published value is quoted to ~0.01 deg and depends slightly on constants.
    assert inclination_deg == pytest.approx(98.60, abs=0.05)


def test_circular_orbit_state_geometry():
    rng = np.random.default_rng(11)
    cases = [(500e3, 51.6, 0.0, 0.0), (400e3, 98.0, 270.0, 123.0), (35786e3, 0.1, 75.0, 10.0)]
    for _ in range(20):
        elements = rng.uniform([100e3, 0.5, 0.0, 0.0], [40000e3, 179.5, 360.0, 360.0])
        cases.append(tuple(elements))
    for altitude, inc_deg, raan_deg, u_deg in cases:
        inc, raan, u = inc_deg * DEG, raan_deg * DEG, u_deg * DEG
        p, v = circular_orbit_state(altitude, inc, raan, u)
        r = R_EARTH_M + altitude
        # Round-off only: a few ulps of 7,000-42,000 km and of km/s speeds.
        assert np.linalg.norm(p) == pytest.approx(r, rel=1e-14)
        assert np.linalg.norm(v) == pytest.approx(math.sqrt(MU / r), rel=1e-14)
        assert abs(np.dot(p, v)) <= 1e-14 * r * np.linalg.norm(v)
        # Elements recovered from the angular momentum h = p x v (independent of the code's
        # rotation sequence): cos i = h_z/|h|; the node vector N = z x h = (-h_y, h_x, 0).
        h = np.cross(p, v)
        assert np.linalg.norm(h) == pytest.approx(math.sqrt(MU * r), rel=1e-14)
        assert math.acos(h[2] / np.linalg.norm(h)) == pytest.approx(inc, abs=1e-12)
        node = np.array([-h[1], h[0], 0.0])
        raan_recovered = math.atan2(node[1], node[0]) % (2.0 * math.pi)
        assert math.cos(raan_recovered - raan) > 0.0
        assert math.sin(raan_recovered - raan) == pytest.approx(0.0, abs=1e-12)
        assert math.sin(raan_of(p, v) - raan) == pytest.approx(0.0, abs=1e-12)
        assert math.cos(raan_of(p, v) - raan) > 0.0
        # Argument of latitude: angle from the ascending node to p, measured in the direction
        # of motion.
        node_hat = node / np.linalg.norm(node)
        cos_u = np.dot(node_hat, p) / r
        sin_u = np.dot(np.cross(node_hat, p), h / np.linalg.norm(h)) / r
        assert math.sin(math.atan2(sin_u, cos_u) - u) == pytest.approx(0.0, abs=1e-12)
        assert math.cos(math.atan2(sin_u, cos_u) - u) > 0.0


@pytest.mark.parametrize("model", ["two_body_j2", "two_body", "cw", "free_space"])
def test_float_hot_path_matches_numpy_gravity(model):
    # gravity_acceleration_xyz (plain floats, used by OrbitalDynamics) must be the same function
    # as gravity_acceleration. Tolerance 1e-15 relative to |a|: a few ulps of reordered sums.
    rng = np.random.default_rng(5)
    for p in _random_points(rng, 50):
        a_ref = gravity_acceleration(p, model)
        a_xyz = np.array(gravity_acceleration_xyz(float(p[0]), float(p[1]), float(p[2]), model))
        scale = max(np.linalg.norm(a_ref), 1e-300)
        np.testing.assert_allclose(a_xyz / scale, a_ref / scale, rtol=0, atol=1e-15)


def _autodiff_gradient(acceleration, p):
    """d acceleration / d p (3, 3) by forward-mode AutoDiffXd through the acceleration itself."""
    return ExtractGradient(acceleration(InitializeAutoDiff(p).reshape(3)))


def test_gravity_gradient_matches_autodiff():
    # LEO on the equator, at 60 and 85 deg latitude and on the pole, MEO, and random points.
    points = [
        [R_EARTH_M + 500e3, 0.0, 0.0],
        [3.4e6, 1.0e5, 5.9e6],
        [4.0e5, -4.0e5, 6.85e6],
        [0.0, 0.0, 6.9e6],
        [1.2e7, -2.0e7, 3.0e6],
        *_random_points(np.random.default_rng(3), 8),
    ]
    for p in np.array(points, dtype=float):
        for model in ("two_body_j2", "two_body", "cw"):
            G = gravity_gradient(p, model)
            G_ad = _autodiff_gradient(lambda q, m=model: gravity_acceleration(q, m), p)
            # 1e-12 of |G|: both are the same derivative evaluated in double precision (measured
            # ~2e-16); a wrong term is an O(1) (two-body) or O(J2) = 1e-3 (J2) miss.
            np.testing.assert_allclose(G, G_ad, rtol=0, atol=1e-12 * np.abs(G_ad).max())
            np.testing.assert_array_equal(G, G.T)  # a Hessian of the potential
        # The J2 part alone, against the J2 scale (the check above sees it only at 1e-3 of |G|).
        G_j2 = gravity_gradient(p, "two_body_j2") - gravity_gradient(p, "two_body")
        G_j2_ad = _autodiff_gradient(j2_acceleration, p)
        np.testing.assert_allclose(G_j2, G_j2_ad, rtol=0, atol=1e-12 * np.abs(G_j2_ad).max())
        np.testing.assert_array_equal(gravity_gradient(p, "free_space"), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="unknown gravity model"):
        gravity_gradient(np.array([7e6, 0.0, 0.0]), "j4")
