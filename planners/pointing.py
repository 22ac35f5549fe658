"""The chaser's attitude as a function of its position: the soft-capture pointing law.

Owns: the minimum-norm rotation between two directions (with the antiparallel case guarded),
the pointing law of paper 000 Sec. IV (the chaser's capture axis points at the target's centre
of mass; between knots the attitude turns by the minimum-norm increment that carries one line of
sight onto the next, so it never rolls about the line of sight), and the Jacobian of that
increment with respect to the chaser position, which Problem 3 needs for eq. (25).
Does not own: attitude dynamics or control (the pointing law is a reference), the collision metric
(rpod.models.collision), or any optimisation.

Conventions: ``p_LC_L`` is the chaser centre of mass relative to the target's centre of mass
(the LVLH origin), expressed in the LVLH frame L; ``R_LC`` maps chaser-body vectors to L; the
capture axis is the unit vector ``c_C`` along ``D_c`` in the chaser body frame C. Small rotations
``theta`` are world-frame (L) and act on the left, ``R -> exp([theta]x) R``, matching
``rpod.models.collision.ScalingMetric``.

Minimum-norm increment and its derivative. For unit ``a`` (previous line of sight) and ``b``
(next), the rotation of least angle taking ``a`` to ``b`` has the unnormalised quaternion
``(s, v) = (1 + a.b, a x b)`` (norm^2 = 2 s). Moving ``b`` by ``db`` turns the increment by the
world-frame angle ``w = (s dv - ds v + v x dv) / s`` with ``ds = a.db``, ``dv = a x db``; with
``(a x b) x (a x db) = ((a x b).db) a`` this is ``w = M db``,

    M = [a]x + (a (a x b)^T - (a x b) a^T) / s,

and ``db = (I - b b^T) dp / |p|`` gives ``d theta_k / d p_k = M (I - b b^T) / |p_k|`` (the earlier
attitudes held fixed, as paper 000 eq. (25) does; the later increments only change the roll about
their own lines of sight, which this first-order term leaves out). At ``a = b``, ``M = [a]x``.
"""

from __future__ import annotations

import numpy as np

from rpod.models.frames import rotations_from_wxyz, skew_rows

# Below this norm of the unnormalised quaternion (1 + a.b, a x b) (it is sqrt(2 (1 + a.b)),
# ~ the angle by which a misses -b), a and b are treated as antiparallel: the least rotation
# is then a half turn about any axis normal to a, and one is chosen deterministically.
_ANTIPARALLEL_TOLERANCE = 1e-9
# Positions shorter than this (m) have no line of sight; the attitude is held.
_MIN_RANGE_M = 1e-9


def _normal_to(a: np.ndarray) -> np.ndarray:
    """A unit vector normal to each unit ``a`` (..., 3): ``a`` x the least-aligned basis axis."""
    basis = np.eye(3)[np.argmin(np.abs(a), axis=-1)]
    n = np.cross(a, basis)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def min_rotation(a_hat: np.ndarray, b_hat: np.ndarray) -> np.ndarray:
    """The rotation of least angle that carries ``a_hat`` onto ``b_hat``.

    Parallel directions give the identity. Antiparallel ones (to ~1e-9 rad) give a half turn
    about a unit axis normal to ``a_hat`` (``a_hat`` x the basis axis least aligned with it),
    the least-angle rotation being non-unique there.

    Args:
        a_hat: Unit vector(s) (3,) or (K, 3).
        b_hat: Unit vector(s) of the same shape.

    Returns:
        Rotation matrices (3, 3) or (K, 3, 3) with ``R a_hat = b_hat``.
    """
    a = np.asarray(a_hat, dtype=float)
    b = np.asarray(b_hat, dtype=float)
    q = np.concatenate([1.0 + np.sum(a * b, axis=-1, keepdims=True), np.cross(a, b)], axis=-1)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    antiparallel = norm[..., 0] < _ANTIPARALLEL_TOLERANCE
    if np.any(antiparallel):
        half_turn = np.concatenate([np.zeros(a.shape[:-1] + (1,)), _normal_to(a)], axis=-1)
        q = np.where(antiparallel[..., None], half_turn, q / np.where(norm > 0.0, norm, 1.0))
    else:
        q = q / norm
    return rotations_from_wxyz(q)


def pointing_attitudes(p_LC_L: np.ndarray, capture_axis_C, R_LC0=None) -> np.ndarray:
    """Chaser attitudes along a path under the pointing law.

    Knot 0: the least rotation that turns the capture axis of ``R_LC0`` (identity if None, i.e.
    the capture axis starts along the corresponding L axis, as in the authors' code) onto the
    line of sight to the target, ``-p_LC_L[0] / |p_LC_L[0]|``. Knot k > 0: the previous attitude
    turned by the least rotation from line of sight k-1 to line of sight k. A position closer
    than 1e-9 m to the target holds the previous line of sight.

    Args:
        p_LC_L: Chaser positions (N, 3) in L [m].
        capture_axis_C: The capture axis in C (3,), e.g. ``D_c``; normalised here.
        R_LC0: Optional chaser attitude (3, 3) before knot 0.

    Returns:
        ``R_LC`` (N, 3, 3).
    """
    p = np.atleast_2d(np.asarray(p_LC_L, dtype=float))
    c_C = np.asarray(capture_axis_C, dtype=float)
    c_C = c_C / np.linalg.norm(c_C)
    los = _lines_of_sight(p)
    R0 = np.eye(3) if R_LC0 is None else np.asarray(R_LC0, dtype=float)
    increments = np.empty((len(p), 3, 3))
    increments[0] = min_rotation(R0 @ c_C, los[0])
    increments[1:] = min_rotation(los[:-1], los[1:])
    R_LC = np.empty_like(increments)
    R = R0
    for k in range(len(p)):  # a running product: each knot's attitude depends on the last
        R = increments[k] @ R
        R_LC[k] = R
    return R_LC


def _lines_of_sight(p: np.ndarray) -> np.ndarray:
    """Unit vectors from the chaser to the target, -p/|p|; a knot at |p| ~ 0 keeps the last."""
    r = np.linalg.norm(p, axis=1)
    los = -p / np.maximum(r, _MIN_RANGE_M)[:, None]
    for k in np.flatnonzero(r < _MIN_RANGE_M):  # rare: a path through the target's centre
        los[k] = los[k - 1] if k > 0 else np.array([0.0, 0.0, -1.0])
    return los


def pointing_rotation_jacobian(p_LC_L: np.ndarray, capture_axis_C, R_LC0=None) -> np.ndarray:
    """``d theta_k / d p_k``: the chaser's world-frame rotation per unit move of knot k.

    The derivative of the pointing-law increment into knot k (from line of sight k-1, or for
    knot 0 from the capture axis of ``R_LC0``) with respect to ``p_LC_L[k]``, earlier attitudes
    held (module docstring). An antiparallel increment has no derivative and gives NaN.

    Args:
        p_LC_L: Chaser positions (N, 3) in L [m], none at the origin.
        capture_axis_C: The capture axis in C (3,), as passed to ``pointing_attitudes``.
        R_LC0: Optional chaser attitude (3, 3) before knot 0, as passed to ``pointing_attitudes``.

    Returns:
        (N, 3, 3): entry [k, i, j] is ``d theta_k[i] / d p_k[j]`` [rad/m].
    """
    p = np.atleast_2d(np.asarray(p_LC_L, dtype=float))
    c_C = np.asarray(capture_axis_C, dtype=float)
    R0 = np.eye(3) if R_LC0 is None else np.asarray(R_LC0, dtype=float)
    r = np.linalg.norm(p, axis=1)
    b = -p / r[:, None]  # lines of sight
    a = np.vstack([R0 @ (c_C / np.linalg.norm(c_C)), b[:-1]])
    s = 1.0 + np.sum(a * b, axis=1)
    v = np.cross(a, b)
    s = np.where(s < _ANTIPARALLEL_TOLERANCE, np.nan, s)
    M = (
        skew_rows(a)
        + (a[:, :, None] * v[:, None, :] - v[:, :, None] * a[:, None, :]) / s[:, None, None]
    )
    db_dp = -(np.eye(3) - b[:, :, None] * b[:, None, :]) / r[:, None, None]  # b = -p / |p|
    return M @ db_dp
