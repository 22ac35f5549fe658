"""The field-of-view relaxation of rpod.planners.soft_capture_socp against eq. (12).

The cones are read back from the built programs (their bindings evaluated at chosen points),
so these tests check the constraint the solver sees, not a copy of its formula.
"""

import numpy as np
import pytest

from rpod.planners.soft_capture import SoftCaptureConfig
from rpod.planners.soft_capture_socp import SoftCaptureSocp

CONFIG = SoftCaptureConfig()
PHI = CONFIG.max_los_rate_rad_s * CONFIG.dt_s  # omega_max dt = 0.2 rad


@pytest.fixture(scope="module")
def problems():
    """Problem 2 and Problem 3 programs at N = 3 (two (FOV) cones each)."""
    return (
        SoftCaptureSocp(CONFIG, 3, with_collision=False),
        SoftCaptureSocp(CONFIG, 3, with_collision=True),
    )


def _cone_margin(binding, values) -> float:
    """z_0 - |z_1:| for z = A v + b of a Lorentz-cone binding: >= 0 inside the cone."""
    z = binding.evaluator().Eval(values)
    return float(z[0] - np.linalg.norm(z[1:]))


def _step(radius, angle, axis=(0.3, -0.5, 0.81)):
    """Two positions of equal norm ``radius`` whose directions differ by ``angle``."""
    a = np.array([1.0, 0.4, -0.2])
    a *= radius / np.linalg.norm(a)
    n = np.cross(a, axis)
    n /= np.linalg.norm(n)
    b = np.cos(angle) * a + np.sin(angle) * radius * n  # a turned by angle about a x axis
    return a, b


@pytest.mark.parametrize("radius", [5.4, 20.0, 50.0, 100.0])
def test_problem2_cone_on_equal_ranges_admits_exactly_the_allowed_turn(problems, radius):
    problem2, _ = problems
    binding = problem2.fov_constraints[0]  # variables [r_0, r_1, rho_0, rho_1]
    # 1e-6 relative inside/outside phi: the margin 2 rho (sin(phi/2) - sin(theta/2)) is then
    # ~rho * 1e-7 >= 5e-7 m, far above round-off (~1e-14 m).
    for angle, inside in [(0.0, True), (0.5 * PHI, True), (PHI * (1 - 1e-6), True),
                          (PHI * (1 + 1e-6), False), (2 * PHI, False), (np.pi / 2, False)]:  # fmt: skip
        r0, r1 = _step(radius, angle)
        margin = _cone_margin(binding, np.concatenate([r0, r1, [radius, radius]]))
        assert (margin >= 0.0) == inside, (radius, angle, margin)


def test_problem2_cone_with_a_tight_lift_never_admits_a_larger_turn(problems):
    # Off the circle the cone is conservative: every admitted step of unequal ranges turns by
    # at most phi (module docstring). Sample steps near the cone's boundary.
    problem2, _ = problems
    binding = problem2.fov_constraints[0]
    rng = np.random.default_rng(3)
    admitted = 0
    for _ in range(3000):
        r0 = rng.normal(size=3) * rng.uniform(3.0, 60.0)
        r1 = r0 * rng.uniform(0.8, 1.25) + rng.normal(size=3) * 0.15 * np.linalg.norm(r0)
        values = np.concatenate([r0, r1, [np.linalg.norm(r0), np.linalg.norm(r1)]])
        if _cone_margin(binding, values) >= 0.0:
            admitted += 1
            angle = np.arctan2(np.linalg.norm(np.cross(r0, r1)), r0 @ r1)
            assert angle <= PHI + 1e-12
    assert admitted > 300  # the sample did probe the admitted region


def test_printed_relaxation_would_cap_the_range_near_11_5_m():
    # The defect this module fixes: paper eq. (24) as printed, |sqrt(H) z| <= sin(phi/2)
    # (rho_k + rho_k+1) with H = [[I, I/2], [I/2, I]], rejects even a zero turn at 20 m for any
    # lift up to r_max, since z^T H z = 3 |r|^2 there.
    H = np.block([[np.eye(3), 0.5 * np.eye(3)], [0.5 * np.eye(3), np.eye(3)]])

    def printed_ok(r):  # the best lift, rho = r_max
        z = np.concatenate([r, r])
        return np.sqrt(z @ H @ z) <= np.sin(PHI / 2) * 2 * CONFIG.max_range_m

    cap = 2 * CONFIG.max_range_m * np.sin(PHI / 2) / np.sqrt(3.0)
    assert 11.4 < cap < 11.6
    assert printed_ok(np.array([0.0, cap * 0.999, 0.0]))
    assert not printed_ok(np.array([0.0, cap * 1.001, 0.0]))


def test_problem3_cone_enforces_the_true_angle_about_any_iterate(problems):
    # (FOV-i) with iterate directions g: on equal ranges along g it admits exactly phi, and
    # anywhere (r turned away from g) it never admits more than phi.
    _, problem3 = problems
    rng = np.random.default_rng(4)
    admitted = 0
    for radius in (5.4, 30.0):
        r0, r1 = _step(radius, 0.0)
        reference = np.vstack([r0, r1, r1])
        problem3.set_linearisation(np.full(3, 2.0), np.zeros((3, 3)), reference)
        binding = problem3.fov_constraints[0]  # variables [r_0, r_1, sigma_0]
        for angle, inside in [(PHI * (1 - 1e-6), True), (PHI * (1 + 1e-6), False)]:
            a, b = _step(radius, angle)
            problem3.set_linearisation(np.full(3, 2.0), np.zeros((3, 3)), np.vstack([a, b, b]))
            assert (_cone_margin(binding, np.concatenate([a, b, [0.0]])) >= 0.0) == inside
        for _ in range(500):
            problem3.set_linearisation(np.full(3, 2.0), np.zeros((3, 3)),
                                       reference + rng.normal(size=(3, 3)))  # fmt: skip
            a = r0 + rng.normal(size=3)
            b = a + rng.normal(size=3) * 0.2 * radius
            if _cone_margin(binding, np.concatenate([a, b, [0.0]])) >= 0.0:
                admitted += 1
                assert np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b) <= PHI + 1e-12
    assert admitted > 50  # the sample did probe the admitted region
