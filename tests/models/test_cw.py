"""Tests for rpod.models.cw against matrix exponentials and the CW closed-form geometry."""

import numpy as np
import pytest
from scipy.linalg import expm

from rpod.models.cw import (
    cw_continuous,
    cw_state_transition,
    cw_zoh_input,
    passively_safe_state,
    safe_ellipse_semi_axes,
)

# LEO (~90 min), GEO-like, and a fast fictitious orbit; short and multi-orbit steps.
MEAN_MOTIONS = [1.1e-3, 7.29e-5, 5e-2]
STEPS = [0.1, 1.0, 60.0, 3000.0, -250.0]


def _scale(M):
    """Entry-wise magnitude floor for relative comparisons."""
    return np.maximum(np.abs(M), 1.0)


@pytest.mark.parametrize("n", MEAN_MOTIONS)
@pytest.mark.parametrize("tau", STEPS)
def test_stm_matches_expm(n, tau):
    A, _ = cw_continuous(n)
    Phi = cw_state_transition(n, tau)
    # Tolerance 1e-9 relative (entries floored at 1): expm's Pade error grows with ||A tau||
    # (secular terms reach ~1e4 at tau = 3000 s, n = 5e-2); the closed form is exact.
    np.testing.assert_allclose(Phi / _scale(Phi), expm(A * tau) / _scale(Phi), atol=1e-9)


@pytest.mark.parametrize("n", MEAN_MOTIONS)
@pytest.mark.parametrize("tau", STEPS)
def test_zoh_matches_augmented_expm(n, tau):
    A, B = cw_continuous(n)
    M = np.zeros((9, 9))
    M[:6, :6] = A
    M[:6, 6:] = B
    E = expm(M * tau)  # [[Phi, B_d], [0, I]] (Van Loan)
    B_d = cw_zoh_input(n, tau)
    # Same 1e-9 relative tolerance and reason as the STM test; B_d entries reach ~tau^2.
    scale = _scale(B_d)
    np.testing.assert_allclose(B_d / scale, E[:6, 6:] / scale, atol=1e-9)


@pytest.mark.parametrize("n", MEAN_MOTIONS)
def test_stm_semigroup_and_identity(n):
    # Exact identities of the closed form; 1e-10 relative covers round-off in the secular terms.
    np.testing.assert_allclose(cw_state_transition(n, 0.0), np.eye(6), atol=1e-15)
    for t1, t2 in [(10.0, 35.0), (1234.0, 4321.0), (500.0, -500.0)]:
        lhs = cw_state_transition(n, t1 + t2)
        rhs = cw_state_transition(n, t2) @ cw_state_transition(n, t1)
        np.testing.assert_allclose(lhs / _scale(lhs), rhs / _scale(lhs), atol=1e-10)


def test_zoh_small_step_limit():
    # For n tau << 1, B_d -> [tau^2/2 I; tau I] (double integrator). The leading neglected term
    # is the Coriolis coupling A B tau^2 / 2 with entries n tau^2 (velocity rows) and
    # n tau^3 / 3 (position rows), so the tolerances are 1.01 times those.
    n, tau = 1.1e-3, 1e-3
    B_d = cw_zoh_input(n, tau)
    np.testing.assert_allclose(
        B_d[:3], 0.5 * tau**2 * np.eye(3), rtol=0, atol=1.01 * n * tau**3 / 3
    )
    np.testing.assert_allclose(B_d[3:], tau * np.eye(3), rtol=0, atol=1.01 * n * tau**2)


def test_rejects_nonpositive_mean_motion():
    with pytest.raises(ValueError, match="mean motion"):
        cw_state_transition(0.0, 1.0)
    with pytest.raises(ValueError, match="mean motion"):
        cw_continuous(-1e-3)


@pytest.mark.parametrize(
    "x, vx, z, vz", [(30.0, 0.0, 0.0, 0.0), (-12.0, 0.05, 8.0, -0.01), (0.0, -0.2, -5.0, 0.0)]
)
def test_passively_safe_state_is_bounded_and_periodic(x, vx, z, vz):
    n = 1.1e-3
    period = 2.0 * np.pi / n
    x0 = passively_safe_state(n, x, vx, z, vz)
    radial, along, cross = safe_ellipse_semi_axes(x0, n)
    assert along == pytest.approx(2.0 * radial, rel=1e-15)

    # Propagate with the exact STM over 10 orbits, 400 samples per orbit.
    times = np.linspace(0.0, 10.0 * period, 4001)
    traj = np.array([cw_state_transition(n, t) @ x0 for t in times])

    # Back to the start after each period: the drift term 6(s - n tau) x0 + (4s - 3 n tau) vy0 / n
    # would grow by 3 n tau x0 per orbit (~600 m for x0 = 30 m) if vy0 != -2 n x0.
    # 1e-9 m absolute: round-off of ~1e2 m entries times n tau ~ 60.
    for k in range(1, 11):
        np.testing.assert_allclose(cw_state_transition(n, k * period) @ x0, x0, atol=1e-9)

    # Bounded and centred: the sampled extent equals the semi-axes. Sampling 400 points per
    # orbit misses a peak by at most A (1 - cos(pi/400)) = 3e-5 A, so tolerance 1e-4 relative.
    tol = 1e-4 * max(radial, cross, 1.0)
    assert np.max(np.abs(traj[:, 0])) == pytest.approx(radial, abs=tol)
    assert np.max(np.abs(traj[:, 1])) == pytest.approx(along, abs=tol)
    assert np.max(np.abs(traj[:, 2])) == pytest.approx(cross, abs=tol)
    # Centred on the target: uniform samples over whole orbits average to zero (exact for
    # sinusoids; 1e-8 m covers round-off on ~1e2 m samples).
    np.testing.assert_allclose(traj[:-1, :3].mean(axis=0), 0.0, atol=1e-8)

    # Every point lies on the ellipse (x/A0)^2 + (y/2A0)^2 = 1 in the orbital plane (exact for
    # the closed form; 1e-9 covers round-off).
    if radial > 0.0:
        on_ellipse = (traj[:, 0] / radial) ** 2 + (traj[:, 1] / along) ** 2
        np.testing.assert_allclose(on_ellipse, 1.0, atol=1e-9)


def test_drifting_state_is_not_periodic():
    # Sanity check that the periodicity test above can fail: perturb vy off the safe value.
    n = 1.1e-3
    x0 = passively_safe_state(n, 30.0, 0.0)
    x0[4] += 1e-3
    after = cw_state_transition(n, 2.0 * np.pi / n) @ x0
    # Along-track drift per orbit is -3 pi dvy / n * 2 = -6 pi dvy / n ~ -17 m.
    assert after[1] - x0[1] == pytest.approx(-6.0 * np.pi * 1e-3 / n, rel=1e-9)


def test_cw_acceleration_is_the_velocity_rows_of_A_x():
    from rpod.models.cw import cw_acceleration

    rng = np.random.default_rng(3)
    n = 0.0011
    A, _ = cw_continuous(n)
    for _ in range(10):
        x = rng.normal(size=6) * [100, 100, 100, 0.1, 0.1, 0.1]
        np.testing.assert_allclose(cw_acceleration(n, x[:3], x[3:]), (A @ x)[3:], rtol=1e-15)
