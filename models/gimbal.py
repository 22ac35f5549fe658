"""Gimbaled thrusters (paper 001 Sec. II-E): force vectors to the body wrench, and their limits.

Owns, as plain numpy functions (one home each, DESIGN.md "Shared laws"):

- the thruster frame K (`thruster_frame_C`) and the force of given gimbal angles (eq. 13);
- the body wrench of thruster force vectors, [tau_C; f_C] = sum_k [p_CK_C x f_k; f_k]
  (eqs. 11-12): `wrench_from_forces` (scalar-generic: float, AutoDiffXd, Expression or CasADi SX
  entries) and the same map as one matrix, `force_to_wrench_matrix` (6, 3n),
  M = [[p_1]x ... [p_n]x; I ... I], built from it;
- the gimbal pyramid of eq. 16: the 4-face pyramid rows (`pyramid_polyhedron`), one thruster's
  (`gimbal_polyhedron`), all thrusters' block-diagonal (A, b) and residuals
  (`gimbal_constraint_matrix`, `gimbal_constraints`);
- the clip of commanded forces into the pyramid and the magnitude ball (eqs. 16-17):
  `GimbalLimits` (built once, for code called every step), `clip_gimbaled_forces`,
  `clip_gimbaled_force`.

Does not own: the layouts, their presets and the fixed-thruster effectiveness matrix
(`rpod.models.thrusters`), the magnitude limit as an NLP constraint and the line-of-sight
pyramid (`rpod.models.coupled_relative`), or applying the clip in time
(`rpod.systems.thruster_bank`).

Thruster frame K (paper 001 Sec. II-E): j_K = -direction_C (the force on the chaser is along -j,
eq. 13; for the paper's layout j_K = p_CK_C/|p_CK_C|). i_K = unit(a x j_K) where a is the C axis
least aligned with j_K (the first one on ties), and k_K = i_K x j_K. The two gimbals of eq. 13
rotate about i_K (alpha2) and k_K (alpha3); the 4-plane pyramid of eq. 16 has its faces
perpendicular to the (i_K, j_K) and (k_K, j_K) planes.
"""

from __future__ import annotations

import math

import numpy as np

from rpod.models.frames import cross_rows
from rpod.models.thrusters import Thruster, ThrusterLayout

# --------------------------------------------------------------------------------------------
# Thruster frame and gimbal angles (eq. 13).


def thruster_frame_C(thruster: Thruster) -> np.ndarray:
    """Rotation R_CK (3 x 3) whose columns are i_K, j_K, k_K expressed in C.

    j_K = -direction_C (thrust along -j, paper 001 eq. 13); i_K = unit(a x j_K) with a the C axis
    least aligned with j_K; k_K = i_K x j_K.
    """
    j = -np.asarray(thruster.direction_C, dtype=float)
    j = j / np.linalg.norm(j)
    a = np.zeros(3)
    a[int(np.argmin(np.abs(j)))] = 1.0
    i = np.cross(a, j)
    i /= np.linalg.norm(i)
    k = np.cross(i, j)
    return np.column_stack([i, j, k])


def force_from_gimbal_angles(
    thruster: Thruster, alpha2_rad: float, alpha3_rad: float, thrust_N: float
) -> np.ndarray:
    """Force on the chaser, in C, for gimbal angles and magnitude (paper 001 eq. 13).

    f_K = -R1(alpha2) R3(alpha3) j |f| in K, with R1, R3 the principal rotations about i_K and
    k_K; returned as R_CK f_K.
    """
    c2, s2 = math.cos(alpha2_rad), math.sin(alpha2_rad)
    c3, s3 = math.cos(alpha3_rad), math.sin(alpha3_rad)
    R1 = np.array([[1.0, 0.0, 0.0], [0.0, c2, -s2], [0.0, s2, c2]])
    R3 = np.array([[c3, -s3, 0.0], [s3, c3, 0.0], [0.0, 0.0, 1.0]])
    f_K = -R1 @ R3 @ np.array([0.0, 1.0, 0.0]) * thrust_N  # eq. 13
    return thruster_frame_C(thruster) @ f_K


# --------------------------------------------------------------------------------------------
# Force vectors to the body wrench (eqs. 11-12).


def wrench_from_forces(layout: ThrusterLayout, f_K_C: np.ndarray) -> np.ndarray:
    """Body wrench [tau_C; f_C] (6,) of thruster force vectors (paper 001 eqs. 11-12).

    Args:
        layout: The layout (its positions are used; limits are not applied here).
        f_K_C: Force of each thruster on the chaser, in C, rows (n, 3) (or 3n stacked), N.
            Object arrays (AutoDiffXd, Expression, CasADi SX) are accepted.
    """
    F = np.asarray(f_K_C).reshape(layout.count, 3)
    P = layout.p_CK_C
    tau_C = cross_rows(P, F).sum(axis=0)  # tau_c = sum_k r_tk x R_k/c f_tk (eq. 12)
    f_C = F.sum(axis=0)  # f_c = sum_k R_k/c f_tk (eq. 11)
    return np.concatenate([tau_C, f_C])


def force_to_wrench_matrix(layout: ThrusterLayout) -> np.ndarray:
    """M (6, 3n) with [tau_C; f_C] = M [f_1; ...; f_n] (eqs. 11-12 are linear in the forces).

    M = [[p_1]x ... [p_n]x; I ... I], built as `wrench_from_forces` of each unit force, so it is
    the same law, not a second copy. Build it once (a few hundred us) and reuse it.
    """
    return np.stack([wrench_from_forces(layout, e) for e in np.eye(3 * layout.count)], axis=1)


# --------------------------------------------------------------------------------------------
# The gimbal pyramid (eq. 16).


def pyramid_polyhedron(axis, lateral_1, lateral_2, half_angle_rad: float) -> np.ndarray:
    """Rows A (4, 3) of the 4-face pyramid {v : A v <= 0} about a unit axis.

    Rows cos(alpha) (+-e) - sin(alpha) a for e in (lateral_1, lateral_2): inside means
    |e.v| <= tan(alpha) a.v for both lateral axes. The three unit vectors must be orthonormal.
    The gimbal pyramid of eq. 16 is this about each thruster's nominal direction; paper 001's
    line-of-sight pyramid (eq. 18, `rpod.models.coupled_relative.los_polyhedron`) has its form.
    """
    a, e1, e2 = (np.asarray(v, dtype=float) for v in (axis, lateral_1, lateral_2))
    ca, sa = math.cos(half_angle_rad), math.sin(half_angle_rad)
    return np.stack([ca * e1 - sa * a, -ca * e1 - sa * a, ca * e2 - sa * a, -ca * e2 - sa * a])


def gimbal_polyhedron(thruster: Thruster) -> tuple[np.ndarray, np.ndarray]:
    """The 4-plane gimbal pyramid A_k f <= b_k of a gimbaled thruster (paper 001 eq. 16).

    With n = direction_C, half-angle alpha and lateral axes e in {i_K, k_K}, the rows are the
    unit normals cos(alpha) (+-e) - sin(alpha) n, b_k = 0 (`pyramid_polyhedron`): the pyramid
    with apex at the origin where |f.e| <= tan(alpha) f.n for both lateral axes. Every force in
    it is reachable with gimbal angles |alpha2|, |alpha3| <= alpha of eq. 13 (the paper's
    "slightly conservative" inner approximation). The magnitude limit (eq. 17) is separate:
    ||f|| <= max_thrust_N.

    Raises:
        ValueError: For a fixed thruster (angle 0): its force set is the segment
            [0, f_max] direction_C, not a pyramid.
    """
    alpha = thruster.gimbal_half_angle_rad
    if alpha <= 0.0:
        raise ValueError("gimbal_polyhedron needs gimbal_half_angle_rad > 0 (fixed thruster)")
    R_CK = thruster_frame_C(thruster)
    A = pyramid_polyhedron(thruster.direction_C, R_CK[:, 0], R_CK[:, 2], alpha)
    return A, np.zeros(4)


def gimbal_constraint_matrix(layout: ThrusterLayout) -> tuple[np.ndarray, np.ndarray]:
    """(A, b) of eq. 16 for all thrusters: A (4 n, 3 n) block-diagonal, b = 0 (4 n,).

    Block k is `gimbal_polyhedron` of thruster k (4 planes at its half-angle about its nominal
    direction, in C), so A @ u <= b is eq. 16 for force vectors u stacked thruster by thruster.
    """
    n = layout.count
    A = np.zeros((4 * n, 3 * n))
    b = np.zeros(4 * n)
    for k, thruster in enumerate(layout.thrusters):
        A_k, b_k = gimbal_polyhedron(thruster)
        A[4 * k : 4 * k + 4, 3 * k : 3 * k + 3] = A_k
        b[4 * k : 4 * k + 4] = b_k
    return A, b


def gimbal_constraints(layout: ThrusterLayout, u) -> np.ndarray:
    """A_k f_k - b_k (4 n,) for all thrusters (eq. 16); <= 0 when satisfied, in N."""
    A, b = gimbal_constraint_matrix(layout)
    return A @ np.asarray(u) - b


# --------------------------------------------------------------------------------------------
# Clip into the pyramid and the magnitude ball (eqs. 16-17).


def clip_gimbaled_forces(
    layout: ThrusterLayout, f_K_C: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Maps commanded thruster forces into each thruster's feasible set (eqs. 16-17).

    Rule, per thruster, with axial a = f.n and lateral l_i = f.i_K, l_k = f.k_K:
    1. a <- max(a, 0); l_i, l_k <- clamp to [-tan(alpha) a, tan(alpha) a] (into the pyramid);
    2. if ||f|| > f_max, f <- f f_max/||f|| (scaling keeps it in the pyramid, a cone).
    A row that already satisfies every limit is returned unchanged, bit for bit. A row with a
    non-finite entry becomes zero force. A fixed thruster (alpha = 0) maps to a n with
    a in [0, f_max]. The result is feasible but is not the Euclidean projection (cheaper, and
    it keeps the commanded axial thrust when only the tilt is too large).

    Args:
        layout: The thrusters (any layout; fixed thrusters get the alpha = 0 rule).
        f_K_C: Commanded forces in C, rows (n, 3) or 3n stacked, N.

    Returns:
        (f_clipped (n, 3), violation (n,)): violation_k >= 0 is the largest amount, in N, by
        which thruster k's command broke a limit (inf for non-finite); 0 when unchanged.
    """
    return GimbalLimits(layout).clip(np.asarray(f_K_C, dtype=float).reshape(layout.count, 3))


def clip_gimbaled_force(thruster: Thruster, f: np.ndarray) -> tuple[np.ndarray, bool]:
    """Maps one force vector into its thruster's feasible set (pyramid of eq. 16 ∩ ball eq. 17).

    See `clip_gimbaled_forces` for the rule; it is the identity on feasible inputs.

    Returns:
        (f_clipped (3,), was_clipped).
    """
    layout = ThrusterLayout(thrusters=[thruster], gimbaled=True)
    f_c, violation = clip_gimbaled_forces(layout, np.asarray(f, dtype=float).reshape(1, 3))
    return f_c[0], bool(violation[0] > 0.0)


class GimbalLimits:
    """A layout's gimbal limits as arrays, built once, for the vectorised clip of eqs. 16-17.

    Use it in code called every step (e.g. a Drake system) instead of `clip_gimbaled_forces`,
    which rebuilds these arrays on each call.
    """

    def __init__(self, layout: ThrusterLayout):
        """Precomputes axes, tan(alpha) and f_max of every thruster of `layout`."""
        frames = [thruster_frame_C(t) for t in layout.thrusters]
        # Per thruster, rows n (nominal force direction), i_K, k_K: F_k -> (a, l_i, l_k).
        self.axes = np.array(
            [np.stack([t.direction_C, R[:, 0], R[:, 2]]) for t, R in zip(layout.thrusters, frames)]
        ).reshape(-1, 3, 3)
        self.tan_alpha = np.tan(layout.gimbal_half_angles_rad)
        self.f_max = layout.max_thrusts_N

    def clip(self, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Same as `clip_gimbaled_forces` for forces F (n, 3); returns (F_clipped, violation)."""
        finite = None
        if not np.all(np.isfinite(F)):
            finite = np.all(np.isfinite(F), axis=1)
            F = np.where(finite[:, None], F, 0.0)
        c = np.einsum("kij,kj->ki", self.axes, F)  # (a, l_i, l_k) per thruster
        a = c[:, 0]
        lateral = np.abs(c[:, 1:]).max(axis=1) - self.tan_alpha * a  # pyramid, eq. 16
        norm = np.sqrt(np.einsum("ij,ij->i", F, F))
        violation = np.maximum(np.maximum(-a, lateral), norm - self.f_max)  # eq. 17
        np.maximum(violation, 0.0, out=violation)  # largest violation, N
        if finite is not None:
            violation[~finite] = np.inf
        bad = violation > 0.0
        if not np.any(bad):
            return F, violation
        a_c = np.maximum(a, 0.0)
        ta_c = (self.tan_alpha * a_c)[:, None]
        c_c = np.concatenate([a_c[:, None], np.clip(c[:, 1:], -ta_c, ta_c)], axis=1)
        G = np.einsum("kij,ki->kj", self.axes, c_c)
        g_norm = np.sqrt(np.einsum("ij,ij->i", G, G))
        scale = np.where(g_norm > self.f_max, self.f_max / np.maximum(g_norm, 1e-300), 1.0)
        G *= scale[:, None]
        return np.where(bad[:, None], G, F), violation
