"""ECI <-> LVLH frame transformations for relative motion.

Owns: the LVLH frame L of the target (x radial out, y along-track, z orbit normal, papers 000 and
004), its attitude R_IL, its exact angular velocity w_IL_L (including the out-of-plane component
that a non-central force such as J2 causes), and the relative position and velocity transforms
both ways, the velocity being the one seen in the rotating frame L.
Does not own: the gravity models (rpod.models.gravity) or the CW linearisation (rpod.models.cw).

Relative vectors are passed as differences (p_TC_I = p_IC_I - p_IT_I) rather than as two absolute
positions: at 7,000 km a subtraction of absolute positions keeps only ~1e-9 m of the digits, and
callers that already hold the difference (the truth integrates it) keep all of them.

Also owns the vector products every model and planner uses (one home, DESIGN.md "Shared laws"):
`cross` and `skew` on one 3-vector, `cross_rows` and `skew_rows` on stacks of them, and
`cross_2d` for planar vectors; and the quaternion algebra of the attitude filters
(`quaternion_product`, `quaternion_conjugate`, `rotation_vector_quaternion`, `attitude_error`). They are written out with products and sums only: faster than
np.cross on 3-vectors (~10 us a call), and they take any scalar type (float, complex for
complex-step derivatives, numpy object arrays of AutoDiffXd, symbolic.Expression or CasADi SX).
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RotationMatrix

# --------------------------------------------------------------------------------------------
# Vector products (any scalar type; see the module docstring).


def cross(a, b) -> np.ndarray:
    """a x b of two 3-vectors (3-sequences), of any scalar type.

    ``tolist()`` turns float64 entries into Python floats, whose arithmetic is several times
    faster than numpy scalars' (np.cross costs ~10 us on 3-vectors); object entries (AutoDiffXd,
    Expression, CasADi SX) pass through as they are.
    """
    a0, a1, a2 = np.asarray(a).tolist()
    b0, b1, b2 = np.asarray(b).tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def rotate_towards(u_from: np.ndarray, u_to: np.ndarray, max_angle: float) -> np.ndarray:
    """The unit vector at most max_angle [rad] from the unit vector u_from on the great circle
    towards the unit vector u_to (u_to itself when it is nearer)."""
    angle = math.acos(min(max(float(u_from @ u_to), -1.0), 1.0))
    if angle <= max_angle:
        return u_to
    axis = cross(u_from, u_to)
    if np.linalg.norm(axis) < 1e-9:  # antiparallel: any perpendicular axis will do
        axis = cross(u_from, [1.0, 0.0, 0.0] if abs(u_from[0]) < 0.9 else [0.0, 1.0, 0.0])
    axis = axis / np.linalg.norm(axis)
    c, s = math.cos(max_angle), math.sin(max_angle)
    return c * u_from + s * cross(axis, u_from)


def skew(w) -> np.ndarray:
    """[w]x (3, 3), the cross-product matrix of a 3-vector: skew(w) @ v = w x v.

    Float entries get a literal 0.0 on the diagonal; other scalar types a zero of their own
    type (0.0 * w0), so that an object array of AutoDiffXd, Expression or CasADi SX comes back.
    """
    w0, w1, w2 = np.asarray(w).tolist()
    zero = 0.0 if isinstance(w0, float) else 0.0 * w0
    return np.array([[zero, -w2, w1], [w2, zero, -w0], [-w1, w0, zero]])


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a x b of two arrays (..., 3) (broadcast against each other) -> (..., 3).

    Float, complex (no conjugation: complex-step derivatives pass through) or object arrays.
    """
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def skew_rows(w: np.ndarray) -> np.ndarray:
    """[w]x for every row of w (..., 3) -> (..., 3, 3), with w's dtype (zeros on the diagonal)."""
    S = np.zeros(w.shape + (3,), dtype=w.dtype)
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    S[..., 1, 0], S[..., 2, 0], S[..., 2, 1] = w[..., 2], -w[..., 1], w[..., 0]
    return S


def cross_2d(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u x v of planar vectors, row-wise: (..., 2) -> (...), the z component u_x v_y - u_y v_x."""
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


# --------------------------------------------------------------------------------------------
# LVLH.


def lvlh_rotation(p_IT_I: np.ndarray, v_IT_I: np.ndarray) -> np.ndarray:
    """R_IL, whose columns are the LVLH axes x (radial), y (along-track), z (normal) in I."""
    x_axis = p_IT_I / np.sqrt(p_IT_I @ p_IT_I)
    h = cross(p_IT_I, v_IT_I)
    z_axis = h / np.sqrt(h @ h)
    return np.column_stack((x_axis, cross(z_axis, x_axis), z_axis))


def lvlh_angular_velocity(p_IT_I: np.ndarray, v_IT_I: np.ndarray, a_IT_I: np.ndarray) -> np.ndarray:
    """w_IL_L, the exact angular velocity of L in I, expressed in L.

    With r = |p|, h = |p x v| and a_n the acceleration along the orbit normal,
    w_IL_L = [r a_n / h, 0, h / r^2]: the z part is the orbital rate; the x part turns the
    orbit plane and vanishes for a central force (it is J2's nodal regression, instantaneously).
    """
    r = np.sqrt(p_IT_I @ p_IT_I)
    h_vec = cross(p_IT_I, v_IT_I)
    h = np.sqrt(h_vec @ h_vec)
    a_normal = np.dot(a_IT_I, h_vec) / h
    return np.array([r * a_normal / h, 0.0, h / (r * r)])


def inertial_to_lvlh(
    R_IL: np.ndarray, w_IL_L: np.ndarray, p_TC_I: np.ndarray, v_TC_I: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Relative state in I -> (p_LC_L, v_LC_L), the velocity as seen in the rotating frame L.

    p_LC_L = R_LI p_TC_I;  v_LC_L = R_LI v_TC_I - w_IL_L x p_LC_L  (transport theorem).
    """
    p_LC_L = R_IL.T @ p_TC_I
    v_LC_L = R_IL.T @ v_TC_I - cross(w_IL_L, p_LC_L)
    return p_LC_L, v_LC_L


def lvlh_to_inertial(
    R_IL: np.ndarray, w_IL_L: np.ndarray, p_LC_L: np.ndarray, v_LC_L: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(p_LC_L, v_LC_L) -> relative state (p_TC_I, v_TC_I) in I; the inverse of inertial_to_lvlh."""
    p_TC_I = R_IL @ p_LC_L
    v_TC_I = R_IL @ (v_LC_L + cross(w_IL_L, p_LC_L))
    return p_TC_I, v_TC_I


def quaternion_wxyz(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix, via pydrake."""
    return RotationMatrix(R).ToQuaternion().wxyz()


def rotation_from_wxyz(q_wxyz: np.ndarray) -> np.ndarray:
    """Rotation matrix of a (not necessarily unit) quaternion (w, x, y, z), via pydrake."""
    q = np.asarray(q_wxyz, dtype=float)
    return RotationMatrix(Quaternion(q / np.linalg.norm(q))).matrix()


def rotations_from_wxyz(q_wxyz) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of quaternions (..., 4) (w, x, y, z), normalised first.

    The vectorised form of `rotation_from_wxyz` for a whole trajectory of attitudes (Hamilton
    convention, as Drake's Quaternion; tests/models/test_frames.py checks it against
    RotationMatrix).
    """
    q = np.asarray(q_wxyz, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = (q[..., i] for i in range(4))
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def rotate_by_wxyz(q_wxyz, v) -> tuple[float, float, float]:
    """R(q) v for a unit quaternion (w, x, y, z), float-only for simulation hot paths.

    v' = v + 2 w (u x v) + 2 u x (u x v), u = (x, y, z): the Rodrigues form of q v q*.
    """
    w, qx, qy, qz = q_wxyz[0], q_wxyz[1], q_wxyz[2], q_wxyz[3]
    vx, vy, vz = v[0], v[1], v[2]
    tx = 2.0 * (qy * vz - qz * vy)
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return (
        vx + w * tx + (qy * tz - qz * ty),
        vy + w * ty + (qz * tx - qx * tz),
        vz + w * tz + (qx * ty - qy * tx),
    )


def quaternion_product(a, b) -> np.ndarray:
    """a (x) b, Hamilton product, (w, x, y, z): R(a (x) b) = R(a) R(b)."""
    # On Python floats: the same IEEE operations as on numpy scalars, several times cheaper.
    aw, ax, ay, az = a.tolist() if isinstance(a, np.ndarray) else a
    bw, bx, by, bz = b.tolist() if isinstance(b, np.ndarray) else b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def quaternion_conjugate(q) -> np.ndarray:
    """The inverse of a unit quaternion."""
    return np.array([q[0], -q[1], -q[2], -q[3]])


def rotation_vector_quaternion(theta) -> np.ndarray:
    """exp(theta / 2): the unit quaternion of the rotation vector theta (3,)."""
    # On Python floats (a quarter of numpy's cost on a 3-vector; it runs at every read of the
    # navigation's estimate).
    tx, ty, tz = np.asarray(theta, dtype=float).tolist()
    angle = math.sqrt(tx * tx + ty * ty + tz * tz)
    if angle < 1e-12:
        hx, hy, hz = 0.5 * tx, 0.5 * ty, 0.5 * tz
        norm = math.sqrt(1.0 + hx * hx + hy * hy + hz * hz)
        return np.array([1.0 / norm, hx / norm, hy / norm, hz / norm])
    scale = math.sin(angle / 2) / angle
    return np.array([math.cos(angle / 2), scale * tx, scale * ty, scale * tz])


def attitude_error(q_ref, q) -> np.ndarray:
    """The rotation vector dtheta with q = q_ref (x) exp(dtheta / 2), the shorter way round."""
    dq = quaternion_product(quaternion_conjugate(q_ref), q)
    if dq[0] < 0.0:
        dq = -dq
    vector = dq[1:]
    sine = float(np.linalg.norm(vector))
    if sine < 1e-12:
        return 2.0 * vector
    return 2.0 * np.arctan2(sine, dq[0]) * vector / sine


def rotation_from_rpy_deg(rpy_deg) -> np.ndarray:
    """Rotation matrix from roll-pitch-yaw angles in degrees (Drake's RollPitchYaw convention)."""
    from pydrake.math import RollPitchYaw

    return RotationMatrix(RollPitchYaw(np.radians(np.asarray(rpy_deg, dtype=float)))).matrix()
