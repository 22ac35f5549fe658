"""Tests for rpod.planners.pointing: least rotations, the pointing law and its Jacobian."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from rpod.planners.pointing import (
    min_rotation,
    pointing_attitudes,
    pointing_rotation_jacobian,
)

CAPTURE_AXIS_C = np.array([0.0, 0.0, 2.7])  # paper 000 Table I, D_c
# Attitudes are products of a few hundred exact rotations: round-off ~1e-15 per product.
ROUND_OFF = 1e-12


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _angle(a, b):
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


def _assert_rotations(R):
    R = np.atleast_3d(R).reshape(-1, 3, 3)
    np.testing.assert_allclose(R @ R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), R.shape),
                               atol=ROUND_OFF)  # fmt: skip
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=ROUND_OFF)


def _random_path(rng, N=60):
    """A wandering path 5-40 m from the target whose line of sight turns < 0.3 rad per step."""
    steps = rng.normal(scale=0.8, size=(N, 3))
    return np.array([12.0, -20.0, 6.0]) + np.cumsum(steps, axis=0)


def test_min_rotation_is_the_least_rotation_onto_b():
    rng = np.random.default_rng(0)
    a = _unit(rng.normal(size=(500, 3)))
    b = _unit(rng.normal(size=(500, 3)))
    R = min_rotation(a, b)
    _assert_rotations(R)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", R, a), b, atol=ROUND_OFF)
    rotvec = Rotation.from_matrix(R).as_rotvec()
    # Any rotation taking a to b turns by at least angle(a, b); the least one turns by exactly
    # that about a x b.
    np.testing.assert_allclose(np.linalg.norm(rotvec, axis=1), _angle(a, b), atol=1e-10)
    np.testing.assert_allclose(np.abs(np.sum(rotvec * a, axis=1)), 0.0, atol=1e-10)
    np.testing.assert_allclose(np.abs(np.sum(rotvec * b, axis=1)), 0.0, atol=1e-10)


def test_min_rotation_parallel_is_identity():
    a = _unit(np.array([0.3, -0.2, 0.9]))
    np.testing.assert_allclose(min_rotation(a, a), np.eye(3), atol=ROUND_OFF)


@pytest.mark.parametrize(
    "a", [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.6, -0.8, 0.0], [0.2, 0.3, -0.93]]
)
def test_min_rotation_antiparallel_is_a_finite_half_turn(a):
    a = _unit(np.asarray(a, dtype=float))
    R = min_rotation(a, -a)
    assert np.all(np.isfinite(R))
    _assert_rotations(R)
    np.testing.assert_allclose(R @ a, -a, atol=ROUND_OFF)
    np.testing.assert_allclose(np.trace(R), -1.0, atol=ROUND_OFF)  # a half turn
    # Nearly antiparallel (1e-12 rad off): still a valid rotation taking a near -a.
    b = _unit(-a + 1e-12 * np.cross(a, [0.31, 0.52, 0.79]))
    R = min_rotation(a, b)
    _assert_rotations(R)
    np.testing.assert_allclose(R @ a, b, atol=1e-9)


def test_pointing_law_points_the_capture_axis_and_never_rolls():
    rng = np.random.default_rng(1)
    p = _random_path(rng)
    R_LC0 = Rotation.random(random_state=rng).as_matrix()
    R_LC = pointing_attitudes(p, CAPTURE_AXIS_C, R_LC0)
    _assert_rotations(R_LC)
    line_of_sight = -_unit(p)
    np.testing.assert_allclose(R_LC @ _unit(CAPTURE_AXIS_C), line_of_sight, atol=ROUND_OFF)
    # Each increment is the least rotation between lines of sight: its angle is theirs, and it
    # has no component about either line of sight (no roll).
    increments = Rotation.from_matrix(R_LC[1:] @ R_LC[:-1].transpose(0, 2, 1)).as_rotvec()
    np.testing.assert_allclose(
        np.linalg.norm(increments, axis=1), _angle(line_of_sight[:-1], line_of_sight[1:]),
        atol=1e-10,
    )  # fmt: skip
    np.testing.assert_allclose(np.sum(increments * line_of_sight[1:], axis=1), 0.0, atol=1e-10)
    # Knot 0 is the least rotation from R_LC0's capture axis onto the first line of sight.
    first = Rotation.from_matrix(R_LC[0] @ R_LC0.T).as_rotvec()
    np.testing.assert_allclose(
        np.linalg.norm(first), _angle(R_LC0 @ _unit(CAPTURE_AXIS_C), line_of_sight[0]), atol=1e-10
    )


def test_radial_motion_keeps_the_attitude():
    # Parallel successive lines of sight: the increment is the identity.
    p = np.outer(np.linspace(30.0, 5.0, 20), _unit(np.array([1.0, 2.0, -2.0])))
    R_LC = pointing_attitudes(p, CAPTURE_AXIS_C)
    np.testing.assert_allclose(R_LC, np.broadcast_to(R_LC[0], R_LC.shape), atol=ROUND_OFF)


def test_start_antiparallel_to_the_initial_capture_axis_is_guarded():
    # Chaser on +z of L: the line of sight is -z while the identity's capture axis is +z.
    p = np.array([[0.0, 0.0, 20.0], [0.5, 0.0, 19.0], [1.0, 0.2, 18.0]])
    R_LC = pointing_attitudes(p, CAPTURE_AXIS_C)
    assert np.all(np.isfinite(R_LC))
    _assert_rotations(R_LC)
    np.testing.assert_allclose(R_LC @ _unit(CAPTURE_AXIS_C), -_unit(p), atol=ROUND_OFF)


def test_rotation_jacobian_matches_finite_differences():
    rng = np.random.default_rng(2)
    p = _random_path(rng, N=8)
    R_LC0 = Rotation.random(random_state=rng).as_matrix()
    J = pointing_rotation_jacobian(p, CAPTURE_AXIS_C, R_LC0)
    h = 1e-5  # m; central differences: truncation ~h^2 |d3R| ~ 1e-11, round-off ~1e-16 / h
    for k in range(len(p)):
        J_fd = np.empty((3, 3))
        for j in range(3):
            plus, minus = p.copy(), p.copy()
            plus[k, j] += h
            minus[k, j] -= h
            R_plus = pointing_attitudes(plus, CAPTURE_AXIS_C, R_LC0)[k]
            R_minus = pointing_attitudes(minus, CAPTURE_AXIS_C, R_LC0)[k]
            J_fd[:, j] = Rotation.from_matrix(R_plus @ R_minus.T).as_rotvec() / (2.0 * h)
        np.testing.assert_allclose(J[k], J_fd, atol=1e-9)
        assert np.abs(J[k]).max() > 1e-3  # a real, non-trivial derivative was compared
