"""Thruster layouts, their wrench maps, gimbal limits, mass flow and wrench allocation.

Owns the equations of the chaser's propulsion, as plain numpy functions and dataclasses:

- `Thruster` / `ThrusterLayout`: where each thruster sits (`p_CK_C`, from the chaser CoM, in the
  chaser body frame C), which way its force on the chaser points (`direction_C`), its limits.
- Presets: `gimbaled_cuboid_8` (paper 001, Fig. 2 and Sec. IV), `planar_8` (paper 003, Fig. 2)
  and `rcs_cube_12` (a 12-thruster 6-DOF reaction-control cube).
- Wrench maps (paper 001 eqs. 11-12, paper 003 eqs. 3-4). A body wrench is ordered like Drake's
  SpatialForce, [tau_C; f_C] (torque about the chaser CoM first, then force), expressed in C.
- The gimbal pointing polyhedron (paper 001 eq. 16), the magnitude limit (eq. 17), the gimbal
  angles of eq. 13 and the projection of a commanded force onto the feasible set.
- Propellant mass flow, mdot = sum_k |f_k| / (Isp_k g0).
- `allocate_duty`: the box-constrained least-squares allocation of paper 003 eq. 14 with an
  exact minimum-fuel tie-break.

It does not own time: the Drake systems that apply these maps every step live in
`rpod.systems.thruster_bank`, `rpod.systems.pwm` and `rpod.systems.allocator`.

Default specific impulse: 220 s, a hydrazine monopropellant thruster (typical 215-235 s in
vacuum). None of the papers gives one; it only matters for propellant bookkeeping.

Thruster frame K (paper 001 Sec. II-E): j_K = -direction_C (the force on the chaser is along -j,
eq. 13; for the paper's layout j_K = p_CK_C/|p_CK_C|). i_K = unit(a x j_K) where a is the C axis
least aligned with j_K (the first one on ties), and k_K = i_K x j_K. The two gimbals of eq. 13
rotate about i_K (alpha2) and k_K (alpha3); the 4-plane pyramid of eq. 16 has its faces
perpendicular to the (i_K, j_K) and (k_K, j_K) planes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize

STANDARD_GRAVITY_M_S2 = 9.80665
"""Standard gravity g0 used in the definition of specific impulse, m/s^2."""

DEFAULT_ISP_S = 220.0
"""Default specific impulse, s: hydrazine monopropellant (none of the papers gives one)."""

_UNIT_TOLERANCE = 1e-9  # |‖d‖ - 1| accepted for a direction given with ~9 significant digits.


@dataclass
class Thruster:
    """One thruster on the chaser.

    Attributes:
        p_CK_C: Position of the thruster point K from the chaser CoM, expressed in C, m (3,).
        direction_C: Unit vector, in C, of the force the thruster applies on the chaser when
            firing (its nominal direction, at zero gimbal angles, for a gimbaled thruster).
        max_thrust_N: Largest force magnitude, N (> 0).
        isp_s: Specific impulse, s (> 0).
        gimbal_half_angle_rad: Half-angle of the gimbal pyramid (paper 001 eq. 16), radians, in
            [0, pi/2); 0 for a fixed thruster.
    """

    p_CK_C: np.ndarray = field(default_factory=lambda: np.zeros(3))
    direction_C: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    max_thrust_N: float = 1.0
    isp_s: float = DEFAULT_ISP_S
    gimbal_half_angle_rad: float = 0.0

    def __post_init__(self):
        self.p_CK_C = np.array(self.p_CK_C, dtype=float)
        self.direction_C = np.array(self.direction_C, dtype=float)


@dataclass
class ThrusterLayout:
    """A set of thrusters on one chaser.

    Attributes:
        thrusters: The thrusters, in command order.
        gimbaled: True when commands are force vectors (3 per thruster, paper 001); False when
            they are on-levels in [0, 1] of fixed-direction thrusters (paper 003).
    """

    thrusters: list[Thruster] = field(default_factory=list)
    gimbaled: bool = False

    @property
    def count(self) -> int:
        """Number of thrusters n."""
        return len(self.thrusters)

    @property
    def command_size(self) -> int:
        """Size of a command vector: n levels (fixed) or 3n force components (gimbaled)."""
        return 3 * self.count if self.gimbaled else self.count

    @property
    def p_CK_C(self) -> np.ndarray:
        """Thruster positions from the chaser CoM, in C, stacked as rows (n, 3), m."""
        return np.array([t.p_CK_C for t in self.thrusters], dtype=float).reshape(-1, 3)

    @property
    def directions_C(self) -> np.ndarray:
        """Unit force directions (nominal for gimbaled thrusters), rows (n, 3)."""
        return np.array([t.direction_C for t in self.thrusters], dtype=float).reshape(-1, 3)

    @property
    def max_thrusts_N(self) -> np.ndarray:
        """Largest force magnitude of each thruster (n,), N."""
        return np.array([t.max_thrust_N for t in self.thrusters], dtype=float)

    @property
    def isps_s(self) -> np.ndarray:
        """Specific impulse of each thruster (n,), s."""
        return np.array([t.isp_s for t in self.thrusters], dtype=float)

    @property
    def gimbal_half_angles_rad(self) -> np.ndarray:
        """Gimbal half-angle of each thruster (n,), rad."""
        return np.array([t.gimbal_half_angle_rad for t in self.thrusters], dtype=float)

    @property
    def max_mass_flows_kg_s(self) -> np.ndarray:
        """Mass flow of each thruster at full thrust (n,), kg/s: f_max / (Isp g0)."""
        return self.max_thrusts_N / (self.isps_s * STANDARD_GRAVITY_M_S2)


def validate_thruster(thruster: Thruster, name: str = "thruster") -> None:
    """Checks one thruster's fields.

    Args:
        thruster: The thruster to check.
        name: How to name it in the error message.

    Raises:
        ValueError: On a non-finite or wrong-shaped vector, a non-unit direction, a
            non-positive thrust or Isp, or a gimbal half-angle outside [0, pi/2).
    """
    p = np.asarray(thruster.p_CK_C, dtype=float)
    d = np.asarray(thruster.direction_C, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ValueError(f"{name}.p_CK_C must be 3 finite numbers (m), got {thruster.p_CK_C!r}")
    if d.shape != (3,) or not np.all(np.isfinite(d)):
        raise ValueError(
            f"{name}.direction_C must be 3 finite numbers, got {thruster.direction_C!r}"
        )
    if abs(np.linalg.norm(d) - 1.0) > _UNIT_TOLERANCE:
        raise ValueError(
            f"{name}.direction_C must be a unit vector, got norm {np.linalg.norm(d):.12g}"
        )
    if not (math.isfinite(thruster.max_thrust_N) and thruster.max_thrust_N > 0.0):
        raise ValueError(f"{name}.max_thrust_N must be > 0 N, got {thruster.max_thrust_N!r}")
    if not (math.isfinite(thruster.isp_s) and thruster.isp_s > 0.0):
        raise ValueError(f"{name}.isp_s must be > 0 s, got {thruster.isp_s!r}")
    alpha = thruster.gimbal_half_angle_rad
    if not (math.isfinite(alpha) and 0.0 <= alpha < math.pi / 2):
        raise ValueError(
            f"{name}.gimbal_half_angle_rad must be in [0, pi/2) rad, got {alpha!r}"
        )


def validate_layout(layout: ThrusterLayout) -> None:
    """Checks every thruster of a layout and the layout's consistency.

    A fixed layout (gimbaled=False) must have zero gimbal angles; a gimbaled one may mix
    gimbaled and fixed (angle 0) thrusters.

    Raises:
        ValueError: With the index of the first bad thruster and the bad field.
    """
    if layout.count == 0:
        raise ValueError("ThrusterLayout.thrusters must not be empty")
    for k, thruster in enumerate(layout.thrusters):
        validate_thruster(thruster, name=f"thrusters[{k}]")
        if not layout.gimbaled and thruster.gimbal_half_angle_rad != 0.0:
            raise ValueError(
                f"thrusters[{k}].gimbal_half_angle_rad is {thruster.gimbal_half_angle_rad!r} "
                "but the layout is not gimbaled (set gimbaled=True or the angle to 0)"
            )


# --------------------------------------------------------------------------------------------
# Presets.


def gimbaled_cuboid_8(
    size: tuple[float, float, float] = (1.5, 4.0, 1.5),
    max_thrust_N: float = 20.0,
    isp_s: float = DEFAULT_ISP_S,
    gimbal_half_angle_rad: float = math.pi / 4,
) -> ThrusterLayout:
    """Eight doubly gimbaled thrusters at the corners of a cuboid chaser (paper 001 Fig. 2).

    The thrusters sit on the corners of the two end faces (y = +-size[1]/2) of the
    1.5 m x 4 m x 1.5 m chaser of paper 001 Sec. IV, i.e. on all eight corners. Nominal thrust
    acts along the line through the thruster and the CoM (Sec. II-B), pushing the chaser inward:
    direction_C = -p_CK_C/|p_CK_C| (j_K = p/|p|, thrust along -j, eq. 13). Sec. IV values:
    f_max = 20 N, gimbal polyhedron angle pi/4.

    Order: face y = +b then y = -b; on each face (+x,+z), (-x,+z), (-x,-z), (+x,-z), so that
    thruster k and k + 4 mirror each other across y = 0 and k, (k + 2) % 4 (+4) are antipodal
    pairs on a face diagonal.

    Args:
        size: Cuboid edge lengths along C's x, y, z, m.
        max_thrust_N: Magnitude limit of eq. 17, N.
        isp_s: Specific impulse, s.
        gimbal_half_angle_rad: Pyramid half-angle of eq. 16, rad.
    """
    a, b, c = (0.5 * float(s) for s in size)
    corners = []
    for sy in (1.0, -1.0):
        for sx, sz in ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)):
            corners.append(np.array([sx * a, sy * b, sz * c]))
    thrusters = [
        Thruster(
            p_CK_C=p,
            direction_C=-p / np.linalg.norm(p),  # thrust along -j_K, j_K = p/|p| (eq. 13)
            max_thrust_N=max_thrust_N,
            isp_s=isp_s,
            gimbal_half_angle_rad=gimbal_half_angle_rad,
        )
        for p in corners
    ]
    layout = ThrusterLayout(thrusters=thrusters, gimbaled=True)
    validate_layout(layout)
    return layout


def planar_8(
    side_m: float = 0.3, max_thrust_N: float = 0.03, isp_s: float = DEFAULT_ISP_S
) -> ThrusterLayout:
    """Eight fixed thrusters on a square planar chaser, two per corner (paper 003 Fig. 2).

    At each corner (sx s/2, sy s/2, 0) one thruster sits on the x-face and fires perpendicular
    to it (force -sx x_C on the chaser: exhaust out of the face) and one on the y-face (force
    -sy y_C). Torques about z are +-s/2 f_max (eq. 4), forces along +-x, +-y (eq. 3); the 8
    columns positively span (f_x, f_y, tau_z), and two same-direction thrusters on the same face
    give a pure force. z components are zero. Defaults: 0.3 m side (the paper's 0.3 m cube
    target, the chaser size is not given) and F_thr = 0.03 N (paper 003 Case Study 2).

    Order: corners (+,+), (-,+), (-,-), (+,-); at each corner the x-face thruster then the
    y-face one.

    Args:
        side_m: Side of the square, m.
        max_thrust_N: Thrust of each thruster when ON (F_thr), N.
        isp_s: Specific impulse, s.
    """
    h = 0.5 * float(side_m)
    thrusters = []
    for sx, sy in ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)):
        p = np.array([sx * h, sy * h, 0.0])
        for d in (np.array([-sx, 0.0, 0.0]), np.array([0.0, -sy, 0.0])):
            thrusters.append(
                Thruster(p_CK_C=p, direction_C=d, max_thrust_N=max_thrust_N, isp_s=isp_s)
            )
    layout = ThrusterLayout(thrusters=thrusters, gimbaled=False)
    validate_layout(layout)
    return layout


def rcs_cube_12(
    side_m: float = 1.0, max_thrust_N: float = 10.0, isp_s: float = DEFAULT_ISP_S
) -> ThrusterLayout:
    """Twelve fixed thrusters, one at the midpoint of each edge of a cube: full 6-DOF control.

    Each thruster fires perpendicular to one of the two faces meeting at its edge (exhaust out
    of that face). With h = side/2:
    - 4 x-thrusters at (sx h, sy h, 0), force -sx x_C: give (f_x, tau_z) = (-sx, sx sy h) f_max;
    - 4 y-thrusters at (0, sy h, sz h), force -sy y_C: give (f_y, tau_x) = (-sy, sy sz h) f_max;
    - 4 z-thrusters at (sx h, 0, sz h), force -sz z_C: give (f_z, tau_y) = (-sz, sx sz h) f_max.
    Each group of four positively spans its (force, torque) plane, so the 12 columns positively
    span R^6: any body wrench is reachable with nonnegative levels. 10 N is a common
    hydrazine RCS size.

    Order: x-group, y-group, z-group; within each group the sign pairs (+,+), (-,+), (-,-), (+,-).

    Args:
        side_m: Cube side, m.
        max_thrust_N: Thrust of each thruster when fully on, N.
        isp_s: Specific impulse, s.
    """
    h = 0.5 * float(side_m)
    signs = ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))
    placements = []
    for s1, s2 in signs:  # x-thrusters on the z-parallel edges
        placements.append(((s1 * h, s2 * h, 0.0), (-s1, 0.0, 0.0)))
    for s1, s2 in signs:  # y-thrusters on the x-parallel edges
        placements.append(((0.0, s1 * h, s2 * h), (0.0, -s1, 0.0)))
    for s1, s2 in signs:  # z-thrusters on the y-parallel edges
        placements.append(((s1 * h, 0.0, s2 * h), (0.0, 0.0, -s2)))
    thrusters = [
        Thruster(
            p_CK_C=np.array(p), direction_C=np.array(d), max_thrust_N=max_thrust_N, isp_s=isp_s
        )
        for p, d in placements
    ]
    layout = ThrusterLayout(thrusters=thrusters, gimbaled=False)
    validate_layout(layout)
    return layout


# --------------------------------------------------------------------------------------------
# Wrench maps.


def _cross_rows(p: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Row-wise p x f of two (n, 3) arrays; written out so AutoDiffXd object arrays work."""
    return np.stack(
        [
            p[:, 1] * f[:, 2] - p[:, 2] * f[:, 1],
            p[:, 2] * f[:, 0] - p[:, 0] * f[:, 2],
            p[:, 0] * f[:, 1] - p[:, 1] * f[:, 0],
        ],
        axis=1,
    )


def wrench_matrix(layout: ThrusterLayout) -> np.ndarray:
    """Control effectiveness matrix B (6 x n) of fixed-direction thrusters.

    Body wrench [tau_C; f_C] = B @ levels with levels in [0, 1]; column k is
    f_max_k [p_CK_C x d_k; d_k] (paper 001 eqs. 11-12, paper 003 eqs. 3-4). For a gimbaled
    layout it is the map at nominal gimbal angles.
    """
    P = layout.p_CK_C
    F = layout.directions_C * layout.max_thrusts_N[:, None]
    B = np.empty((6, layout.count))
    B[:3] = _cross_rows(P, F).T  # tau = sum_k p_k x f_k (paper 001 eq. 12, paper 003 eq. 4)
    B[3:] = F.T  # f = sum_k f_k (paper 001 eq. 11, paper 003 eq. 3)
    return B


def wrench_from_forces(layout: ThrusterLayout, f_K_C: np.ndarray) -> np.ndarray:
    """Body wrench [tau_C; f_C] (6,) of thruster force vectors (paper 001 eqs. 11-12).

    Args:
        layout: The layout (its positions are used; limits are not applied here).
        f_K_C: Force of each thruster on the chaser, in C, rows (n, 3) (or 3n stacked), N.
            Object arrays of AutoDiffXd are accepted.
    """
    F = np.asarray(f_K_C).reshape(layout.count, 3)
    P = layout.p_CK_C
    tau_C = _cross_rows(P, F).sum(axis=0)  # tau_c = sum_k r_tk x R_k/c f_tk (eq. 12)
    f_C = F.sum(axis=0)  # f_c = sum_k R_k/c f_tk (eq. 11)
    return np.concatenate([tau_C, f_C])


# --------------------------------------------------------------------------------------------
# Gimbal geometry (paper 001 eqs. 13, 16, 17).


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


def gimbal_polyhedron(thruster: Thruster) -> tuple[np.ndarray, np.ndarray]:
    """The 4-plane gimbal pyramid A_k f <= b_k of a gimbaled thruster (paper 001 eq. 16).

    With n = direction_C, half-angle alpha and lateral axes e in {i_K, k_K}, the rows are the
    unit normals cos(alpha) (+-e) - sin(alpha) n, b_k = 0: the pyramid with apex at the origin
    where |f.e| <= tan(alpha) f.n for both lateral axes. Every force in it is reachable with
    gimbal angles |alpha2|, |alpha3| <= alpha of eq. 13 (the paper's "slightly conservative"
    inner approximation). The magnitude limit (eq. 17) is separate: ||f|| <= max_thrust_N.

    Raises:
        ValueError: For a fixed thruster (angle 0): its force set is the segment
            [0, f_max] direction_C, not a pyramid.
    """
    alpha = thruster.gimbal_half_angle_rad
    if alpha <= 0.0:
        raise ValueError("gimbal_polyhedron needs gimbal_half_angle_rad > 0 (fixed thruster)")
    R_CK = thruster_frame_C(thruster)
    n = np.asarray(thruster.direction_C, dtype=float)
    e_i, e_k = R_CK[:, 0], R_CK[:, 2]
    ca, sa = math.cos(alpha), math.sin(alpha)
    A = np.stack([ca * e_i - sa * n, -ca * e_i - sa * n, ca * e_k - sa * n, -ca * e_k - sa * n])
    return A, np.zeros(4)


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


# --------------------------------------------------------------------------------------------
# Propellant.


def mass_flow_rate(layout: ThrusterLayout, thrust_magnitudes_N: np.ndarray) -> float:
    """Total propellant mass flow, kg/s: sum_k |f_k| / (Isp_k g0).

    Args:
        layout: The thrusters (their Isp).
        thrust_magnitudes_N: Force magnitude of each thruster (n,), N (absolute value used).
    """
    f = np.abs(np.asarray(thrust_magnitudes_N, dtype=float).reshape(layout.count))
    return float(np.sum(f / (layout.isps_s * STANDARD_GRAVITY_M_S2)))


# --------------------------------------------------------------------------------------------
# Allocation (paper 003 eq. 14).


def allocate_duty(
    B: np.ndarray,
    w: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    minimize_fuel: bool = True,
    fuel_cost: np.ndarray | None = None,
) -> np.ndarray:
    """Duty levels u = argmin ||W (B u - w)||^2 s.t. 0 <= u <= 1 (paper 003 eq. 14).

    Two lexicographic stages, so the tie-break never costs accuracy:
    1. scipy.optimize.lsq_linear, method 'bvls' (an exact active-set method), tol 1e-12: the
       weighted wrench y* = W B u1 closest to W w is unique even when u1 is not.
    2. If minimize_fuel: among all u with W B u = y* and 0 <= u <= 1 (all optimal allocations),
       minimise fuel_cost . u by a HiGHS LP; its vertex is then re-solved exactly on its free
       set (least squares on the basic columns) so the equality holds to machine precision.
       The stage-2 result is kept only if its fit is as good as stage 1's (to 1e-12 relative)
       and it is cheaper; otherwise u1 is returned.
    So a feasible wrench (w = B u for some u in the box) is reproduced to round-off, and an
    infeasible one gets the (weighted) least-squares optimum.

    Args:
        B: Effectiveness matrix (m, n), e.g. `wrench_matrix(layout)`.
        w: Desired wrench (m,).
        weights: Diagonal of W (m,), each >= 0 (None: all ones).
        minimize_fuel: Run stage 2.
        fuel_cost: Cost of each unit of u_k in stage 2 (n,), > 0 (None: all ones; pass
            `layout.max_mass_flows_kg_s` for propellant mass).

    Returns:
        u (n,) with every entry in [0, 1].
    """
    B = np.asarray(B, dtype=float)
    w = np.asarray(w, dtype=float).reshape(B.shape[0])
    n = B.shape[1]
    W = np.ones(B.shape[0]) if weights is None else np.asarray(weights, dtype=float)
    if W.shape != (B.shape[0],) or np.any(W < 0) or not np.any(W > 0):
        raise ValueError(f"weights must be {B.shape[0]} numbers >= 0, not all 0; got {weights!r}")
    if not np.all(np.isfinite(w)):
        return np.zeros(n)
    Bw = W[:, None] * B
    ww = W * w
    # Stage 1: box-constrained least squares (paper 003 eq. 14).
    result = scipy.optimize.lsq_linear(Bw, ww, bounds=(0.0, 1.0), method="bvls", tol=1e-12)
    u1 = np.clip(result.x, 0.0, 1.0)
    if not minimize_fuel:
        return u1
    c = np.ones(n) if fuel_cost is None else np.asarray(fuel_cost, dtype=float).reshape(n)
    if np.any(c <= 0) or not np.all(np.isfinite(c)):
        raise ValueError(f"fuel_cost must be {n} finite numbers > 0, got {fuel_cost!r}")
    c = c / np.max(c)  # scale-free LP (mass flows are ~1e-3 kg/s)
    y = Bw @ u1
    U, s, Vt = np.linalg.svd(Bw, full_matrices=False)
    rank = int(np.sum(s > s[0] * 1e-12)) if s.size and s[0] > 0 else 0
    if rank == 0:
        return np.zeros(n)
    # Row space of W B: W B u = y*  <=>  Vt_r u = diag(1/s_r) U_r^T y*  (exact, well scaled).
    A_eq = Vt[:rank]
    b_eq = (U[:, :rank].T @ y) / s[:rank]
    lp = scipy.optimize.linprog(
        c,
        A_eq=A_eq,
        b_eq=b_eq,
        bounds=(0.0, 1.0),
        method="highs",
        options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10},
    )
    if lp.status != 0 or lp.x is None:
        return u1
    u2 = np.clip(lp.x, 0.0, 1.0)
    # Polish the vertex: fix its bound entries, solve the free ones exactly.
    at_lower = u2 <= 1e-9
    at_upper = u2 >= 1.0 - 1e-9
    free = ~(at_lower | at_upper)
    u2 = np.where(at_upper, 1.0, 0.0)
    if np.any(free):
        rhs = y - Bw[:, ~free] @ u2[~free]
        u_free = np.linalg.lstsq(Bw[:, free], rhs, rcond=None)[0]
        if np.any(u_free < -1e-9) or np.any(u_free > 1.0 + 1e-9):
            return u1
        u2[free] = np.clip(u_free, 0.0, 1.0)
    r1 = np.linalg.norm(Bw @ u1 - ww)
    r2 = np.linalg.norm(Bw @ u2 - ww)
    scale = np.linalg.norm(ww) + np.linalg.norm(y) + 1e-300
    if r2 <= r1 + 1e-12 * scale and c @ u2 < c @ u1:
        return u2
    return u1
