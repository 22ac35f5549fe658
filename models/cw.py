"""Clohessy-Wiltshire (Hill) relative motion about a circular target orbit.

Owns: the continuous CW model, its exact state-transition matrix and zero-order-hold input
matrix, and the passively safe (bounded, drift-free) relative orbits used as start states.
Does not own: nonlinear orbital truth dynamics, the LVLH <-> ECI transforms, or any planner.

State ``x_L = [x, y, z, vx, vy, vz]`` is the chaser position and velocity relative to the target,
expressed in the target's LVLH frame L (x radial out, y along-track, z orbit normal); the input
is the chaser's control acceleration expressed in L [m/s^2]. ``n`` is the target's mean motion
[rad/s] and must be positive.

The functions build their arrays without forcing a dtype, so ``n`` and ``tau`` may be
``AutoDiffXd`` scalars (numpy object arrays come back) when a planner wants derivatives.
"""

import numpy as np


def _check_mean_motion(n) -> None:
    n_value = n.value() if hasattr(n, "value") else n  # AutoDiffXd or float
    if not float(n_value) > 0.0:
        raise ValueError(f"mean motion n must be positive, got {n}")


def cw_continuous(n) -> tuple[np.ndarray, np.ndarray]:
    """Continuous-time CW matrices ``x_dot = A x + B u``.

    Args:
        n: Target mean motion [rad/s], > 0.

    Returns:
        ``(A, B)`` with shapes (6, 6) and (6, 3); ``u`` is an acceleration in L [m/s^2].
    """
    _check_mean_motion(n)
    zero = 0.0 * n
    A = np.array(
        [
            [zero, zero, zero, 1.0 + zero, zero, zero],
            [zero, zero, zero, zero, 1.0 + zero, zero],
            [zero, zero, zero, zero, zero, 1.0 + zero],
            [3.0 * n * n, zero, zero, zero, 2.0 * n, zero],  # paper 004 eq. (4), x_ddot
            [zero, zero, zero, -2.0 * n, zero, zero],  # paper 004 eq. (4), y_ddot
            [zero, zero, -n * n, zero, zero, zero],  # paper 004 eq. (4), z_ddot
        ]
    )
    B = np.vstack([np.zeros((3, 3)), np.eye(3)])
    return A, B


def cw_acceleration(n, p_L, v_L) -> np.ndarray:
    """The unforced CW acceleration in L (paper 004 eq. 4): the A x of `cw_continuous`, written
    out for one state (a controller's feed-forward cancels it, paper 004 eq. 12).

    Args:
        n: Target mean motion [rad/s].
        p_L: Relative position (3,) in L [m].
        v_L: Relative velocity (3,) in L [m/s].
    """
    return np.array([3.0 * n * n * p_L[0] + 2.0 * n * v_L[1], -2.0 * n * v_L[0], -n * n * p_L[2]])


def cw_state_transition(n, tau) -> np.ndarray:
    """Exact CW state-transition matrix ``Phi(tau) = expm(A tau)``.

    Paper 004 prints eq. (6) with the z and vz columns merged (five columns); this is the full
    6x6 matrix, derived from the closed-form solution of eq. (4).

    Args:
        n: Target mean motion [rad/s], > 0.
        tau: Propagation time [s] (any sign).

    Returns:
        ``Phi`` (6, 6) with ``x(t + tau) = Phi x(t)`` for unforced motion.
    """
    _check_mean_motion(n)
    nt = n * tau
    c, s = np.cos(nt), np.sin(nt)
    one_minus_c = 2.0 * np.sin(0.5 * nt) ** 2  # 1 - cos(n tau) without cancellation
    zero = 0.0 * nt
    one = 1.0 + zero
    # Rows: x, y, z, vx, vy, vz; columns: x0, y0, z0, vx0, vy0, vz0. Paper 004 eq. (6).
    return np.array(
        [
            [4.0 - 3.0 * c, zero, zero, s / n, 2.0 * one_minus_c / n, zero],
            [6.0 * (s - nt), one, zero, -2.0 * one_minus_c / n, (4.0 * s - 3.0 * nt) / n, zero],
            [zero, zero, c, zero, zero, s / n],
            [3.0 * n * s, zero, zero, c, 2.0 * s, zero],
            [-6.0 * n * one_minus_c, zero, zero, -2.0 * s, 4.0 * c - 3.0, zero],
            [zero, zero, -n * s, zero, zero, c],
        ]
    )


def cw_zoh_input(n, tau) -> np.ndarray:
    """Exact zero-order-hold input matrix ``B_d(tau) = int_0^tau Phi(s) B ds``.

    With ``Phi = cw_state_transition(n, tau)`` and a constant acceleration ``u`` held over the
    step, ``x(t + tau) = Phi x(t) + B_d u`` (paper 004 eq. (5) without the noise term).

    Args:
        n: Target mean motion [rad/s], > 0.
        tau: Step length [s].

    Returns:
        ``B_d`` (6, 3).
    """
    _check_mean_motion(n)
    nt = n * tau
    s = np.sin(nt)
    one_minus_c = 2.0 * np.sin(0.5 * nt) ** 2
    zero = 0.0 * nt
    n2 = n * n
    # Columns are the time integrals of the vx0, vy0, vz0 columns of Phi (paper 004 eq. (6)).
    return np.array(
        [
            [one_minus_c / n2, 2.0 * (nt - s) / n2, zero],
            [-2.0 * (nt - s) / n2, 4.0 * one_minus_c / n2 - 1.5 * tau * tau, zero],
            [zero, zero, one_minus_c / n2],
            [s / n, 2.0 * one_minus_c / n, zero],
            [-2.0 * one_minus_c / n, 4.0 * s / n - 3.0 * tau, zero],
            [zero, zero, s / n],
        ]
    )


def passively_safe_state(
    n: float, x: float, vx: float, z: float = 0.0, vz: float = 0.0
) -> np.ndarray:
    """A state on a bounded, drift-free CW relative orbit centred on the target.

    The radial and cross-track components are free; the along-track ones follow from paper 000
    eq. (6): ``vy = -2 n x`` cancels the secular drift and ``y = 2 vx / n`` centres the ellipse
    on the target.

    Args:
        n: Target mean motion [rad/s], > 0.
        x: Radial position [m].
        vx: Radial velocity [m/s].
        z: Cross-track position [m].
        vz: Cross-track velocity [m/s].

    Returns:
        ``x_L`` (6,) = ``[x, 2 vx / n, z, vx, -2 n x, vz]``.
    """
    _check_mean_motion(n)
    vy = -2.0 * n * x  # paper 000 eq. (6), no along-track drift
    y = 2.0 * vx / n  # paper 000 eq. (6), ellipse centred on the target
    return np.array([x, y, z, vx, vy, vz], dtype=float)


def safe_ellipse_semi_axes(state_L: np.ndarray, n: float) -> tuple[float, float, float]:
    """Semi-axes of the relative orbit through a passively safe state.

    Paper 000 eq. (7) prints ``A0 = sqrt((r_x/n)^2 + r_x^2)``; the correct amplitude of
    ``x(t) = x0 cos(nt) + (vx0/n) sin(nt)`` is ``sqrt((vx0/n)^2 + x0^2)``, and likewise for z.

    Args:
        state_L: CW state (6,) satisfying paper 000 eq. (6) (e.g. from ``passively_safe_state``).
        n: Target mean motion [rad/s], > 0.

    Returns:
        ``(radial, along_track, cross_track)`` semi-axes = ``(A0, 2 A0, B0)`` [m].
    """
    _check_mean_motion(n)
    x, _, z, vx, _, vz = np.asarray(state_L, dtype=float)
    A0 = float(np.hypot(vx / n, x))  # paper 000 eq. (7), corrected
    B0 = float(np.hypot(vz / n, z))  # paper 000 eq. (7)
    return A0, 2.0 * A0, B0
