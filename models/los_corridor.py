"""Paper 004's rotating line-of-sight corridor: a polyhedral cone fixed in the target body.

Owns: `LosCorridor` (the cone about the target's +y body axis, half-angle alpha_c, n_f faces and
a floor, as A_c p_T <= b_c, eqs. 9-10), the synchronisation range r_sync (eq. 14) and the
body-frame relative state with its transport term (eqs. 7-8).
Does not own: the circular docking cone of paper 000 (rpod.models.docking, a different shape:
both are kept, named apart), the MPC that keeps a chaser inside this one, or the analysis of
where it can.

The faces. Face i (i = 1..n_f) is cos(theta_i) x_T + sin(theta_i) z_T <= tan(alpha_c) y_T with
theta_i = 2 pi (i - 1) / n_f (eq. 9): each is tangent to the circular cone of half-angle
alpha_c along the direction theta_i, so the polyhedral cone contains the circular one (its
edges reach atan(tan(alpha_c) / cos(pi / n_f)), 32.0 deg for 30 deg and 8 faces). The floor is
y_T >= y_min. Paper 004 names the body frame B; it is rpod's target frame T.
"""

import dataclasses
import math

import numpy as np

VIOLATION_TOLERANCE_M = 1e-3  # paper 004 Sec. 9: a chaser further outside than this violates


@dataclasses.dataclass(frozen=True)
class LosCorridor:
    """The corridor, A_c p_T <= b_c in the target body frame (module docstring).

    Attributes:
        half_angle_rad: alpha_c (paper 004 Table 1: 30 deg).
        faces: n_f (Table 1: 8).
        floor_m: y_min, the corridor's floor along +y_T [m] (Table 1: 1 m).
    """

    half_angle_rad: float = math.radians(30.0)
    faces: int = 8
    floor_m: float = 1.0

    def __post_init__(self):
        if not 0.0 < self.half_angle_rad < math.pi / 2:
            raise ValueError(f"half_angle_rad must be in (0, pi/2), got {self.half_angle_rad}")
        if self.faces < 3:
            raise ValueError(f"faces must be at least 3, got {self.faces}")
        if not (math.isfinite(self.floor_m) and self.floor_m >= 0.0):
            raise ValueError(f"floor_m must be >= 0, got {self.floor_m}")

    @property
    def A_c(self) -> np.ndarray:
        """(n_f + 1, 3): the faces' rows [cos theta_i, -tan alpha_c, sin theta_i], then the
        floor's [0, -1, 0] (eq. 9)."""
        theta = 2.0 * math.pi * np.arange(self.faces) / self.faces
        faces = np.column_stack(
            [np.cos(theta), np.full(self.faces, -math.tan(self.half_angle_rad)), np.sin(theta)]
        )
        return np.vstack([faces, [0.0, -1.0, 0.0]])

    @property
    def b_c(self) -> np.ndarray:
        """(n_f + 1,): zeros for the faces, -y_min for the floor (eq. 9)."""
        return np.concatenate([np.zeros(self.faces), [-self.floor_m]])

    def slack(self, p_T) -> np.ndarray:
        """b_c - A_c p_T for one point (3,) or many (K, 3): >= 0 on every row inside."""
        p = np.asarray(p_T, dtype=float)
        return self.b_c - p @ self.A_c.T

    def contains(self, p_T, tolerance_m: float = 0.0) -> bool | np.ndarray:
        """Inside (every row's slack >= -tolerance), for one point or each of many."""
        return np.all(self.slack(p_T) >= -tolerance_m, axis=-1)

    def in_lvlh(self, R_LT) -> tuple[np.ndarray, np.ndarray]:
        """(A, b) with A p_L <= b the same corridor for a point in L, when the target's
        attitude is R_LT: A = A_c R_LT^T (eq. 10's A_c R_z(-omega_t t) for a spin about z)."""
        return self.A_c @ np.asarray(R_LT, dtype=float).T, self.b_c


def corridor_frame_R_TK(axis_T) -> np.ndarray:
    """R_TK of a corridor frame K whose +y_K is the unit `axis_T` (a docking axis in T): the
    frame in which a corridor about any body axis is this module's cone about +y. x_K is the
    T axis least aligned with the axis, made orthogonal to it; z_K = x_K x y_K. The identity
    for axis_T = +y_T."""
    y = np.asarray(axis_T, dtype=float)
    y = y / np.linalg.norm(y)
    hint = np.eye(3)[int(np.argmin(np.abs(y)))]  # x_T for +y_T (the first of a tie)
    x = hint - (hint @ y) * y
    x = x / np.linalg.norm(x)
    return np.column_stack((x, y, np.cross(x, y)))


def sync_range_m(a_max_m_s2: float, omega_t_rad_s: float) -> float:
    """r_sync = 2 a_max / omega_t^2 (eq. 14): beyond it, a chaser that brakes at a_max cannot
    take out the body frame's apparent speed omega_t r within the range r."""
    if not (a_max_m_s2 > 0 and omega_t_rad_s != 0):
        raise ValueError("a_max must be positive and omega_t non-zero")
    return 2.0 * a_max_m_s2 / omega_t_rad_s**2


def holding_range_m(a_max_m_s2: float, omega_t_rad_s: float) -> float:
    """r_hold = a_max / omega_t^2 = r_sync / 2: the farthest range at which a chaser at rest in
    the tumbling frame can stay there. Holding a point at rest in T takes the centripetal
    acceleration omega_t^2 r (the point turns on a circle of radius r), and the box supplies at
    most a_max; so a hold point beyond r_hold cannot be held, and a start at rest between r_hold
    and r_sync can be braked (eq. 14) but not kept where it is. r_sync is necessary for the
    approach; r_hold is what a hold needs."""
    return 0.5 * sync_range_m(a_max_m_s2, omega_t_rad_s)


# The share of the box a suggested hold point leaves to the centripetal acceleration: half,
# the rest for control (r = r_sync / 4, as the Table 3 campaign holds).
HOLD_MARGIN = 0.5


def suggested_hold_distance_m(a_max_m_s2: float, omega_t_rad_s: float) -> float:
    """The range at which holding at rest in T takes HOLD_MARGIN of the box: r_hold HOLD_MARGIN
    = r_sync / 4 [m]."""
    return HOLD_MARGIN * holding_range_m(a_max_m_s2, omega_t_rad_s)


def body_relative_state(R_IT, w_IT_T, p_IC_I, v_IC_I, p_IT_I, v_IT_I):
    """(p_TC_T, v_TC_T): the chaser relative to the tumbling target, in and seen from T.

    p_T = R_IT^T (r_c - r_t)                        (eq. 7)
    v_T = R_IT^T (v_c - v_t) - w_IT_T x p_T          (eq. 8, the transport term)

    so that a chaser at rest in T (co-rotating, v_c - v_t = w x r in I) has v_T = 0.
    """
    R_TI = np.asarray(R_IT, dtype=float).T
    p_T = R_TI @ (np.asarray(p_IC_I, dtype=float) - np.asarray(p_IT_I, dtype=float))
    v_T = R_TI @ (np.asarray(v_IC_I, dtype=float) - np.asarray(v_IT_I, dtype=float))
    return p_T, v_T - np.cross(np.asarray(w_IT_T, dtype=float), p_T)
