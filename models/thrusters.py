"""Thruster layouts, the fixed-thruster wrench map, mass flow and wrench allocation.

Owns the equations of the chaser's propulsion, as plain numpy functions and dataclasses:

- `Thruster` / `ThrusterLayout`: where each thruster sits (`p_CK_C`, from the chaser CoM, in the
  chaser body frame C), which way its force on the chaser points (`direction_C`), its limits.
- Presets: `gimbaled_cuboid_8` (paper 001, Fig. 2 and Sec. IV), `planar_8` (paper 003, Fig. 2)
  and `rcs_cube_12` (a 12-thruster 6-DOF reaction-control cube).
- The effectiveness matrix of fixed-direction thrusters, `wrench_matrix` (paper 003 eqs. 3-4).
  A body wrench is ordered like Drake's SpatialForce, [tau_C; f_C] (torque about the chaser
  CoM first, then force), expressed in C.
- Propellant mass flow, mdot = sum_k |f_k| / (Isp_k g0).
- `allocate_duty` / `DutyAllocator`: the box-constrained least-squares allocation of paper 003
  eq. 14 with an exact minimum-fuel tie-break (`allocate_duty_reference`: the scipy version).

Does not own: gimbaled thrusters (force vectors to the wrench, eqs. 11-12; the thruster frame
and gimbal angles, eq. 13; the gimbal pyramid and the clip, eqs. 16-17), which live in
`rpod.models.gimbal`;
the cross product (`rpod.models.frames.cross_rows`); time: the Drake systems that apply these
maps every step live in `rpod.systems.thruster_bank`, `rpod.systems.pwm` and
`rpod.systems.allocator`.

Default specific impulse: 220 s, a hydrazine monopropellant thruster (typical 215-235 s in
vacuum). None of the papers gives one; it only matters for propellant bookkeeping.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from rpod.models.frames import cross_rows

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
        raise ValueError(f"{name}.gimbal_half_angle_rad must be in [0, pi/2) rad, got {alpha!r}")


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


def wrench_matrix(layout: ThrusterLayout) -> np.ndarray:
    """Control effectiveness matrix B (6 x n) of fixed-direction thrusters.

    Body wrench [tau_C; f_C] = B @ levels with levels in [0, 1]; column k is
    f_max_k [p_CK_C x d_k; d_k] (paper 001 eqs. 11-12, paper 003 eqs. 3-4). For a gimbaled
    layout it is the map at nominal gimbal angles.
    """
    P = layout.p_CK_C
    F = layout.directions_C * layout.max_thrusts_N[:, None]
    B = np.empty((6, layout.count))
    B[:3] = cross_rows(P, F).T  # tau = sum_k p_k x f_k (paper 001 eq. 12, paper 003 eq. 4)
    B[3:] = F.T  # f = sum_k f_k (paper 001 eq. 11, paper 003 eq. 3)
    return B


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

_BOX_SLACK_TOL = 1e-10
"""Largest excursion of a basis' levels outside [0, 1] (duty units) accepted as round-off; the
levels are then clipped. The basis solve itself is exact to ~1e-15."""

_TIE_TOL = 1e-9
"""Reduced fuel cost (fuel cost scaled to a largest entry of 1) at or below which two vertices
count as equally cheap, so that the secondary tie-break decides between them."""

_KKT_TOL = 1e-11
"""Bound multiplier violation accepted by the box least-squares stage, relative to
||(W B)^T W w|| (the tests require 1e-9)."""

_MIN_BASIS_SINGULAR_VALUE = 1e-8
"""Column subsets of the (orthonormal-row) equality matrix whose smallest singular value is
below this are not bases (for the presets they are exactly singular, ~1e-16)."""

_FREE_SET_CACHE_SIZE = 4096
"""Free sets whose Gram inverse `DutyAllocator` keeps (cleared when full)."""

MAX_ENUMERATED_BASES = 20000
"""Largest number of candidate bases C(n, rank) enumerated by `DutyAllocator`; above it the
allocator uses `allocate_duty_reference` (rcs_cube_12: C(12, 6) = 924, planar_8: C(8, 3) = 56)."""


def _first_primes(count: int) -> np.ndarray:
    """The first `count` prime numbers, as floats."""
    primes: list[int] = []
    k = 2
    while len(primes) < count:
        if all(k % p for p in primes if p * p <= k):
            primes.append(k)
        k += 1
    return np.array(primes, dtype=float)


def _validated_weights(weights: np.ndarray | None, m: int) -> np.ndarray:
    W = np.ones(m) if weights is None else np.asarray(weights, dtype=float)
    if W.shape != (m,) or not np.all(np.isfinite(W)) or np.any(W < 0) or not np.any(W > 0):
        raise ValueError(f"weights must be {m} numbers >= 0, not all 0; got {weights!r}")
    return W


def _validated_fuel_cost(fuel_cost: np.ndarray | None, n: int) -> np.ndarray:
    c = np.ones(n) if fuel_cost is None else np.asarray(fuel_cost, dtype=float).reshape(n)
    if np.any(c <= 0) or not np.all(np.isfinite(c)):
        raise ValueError(f"fuel_cost must be {n} finite numbers > 0, got {fuel_cost!r}")
    return c


class DutyAllocator:
    """The problem of `allocate_duty` for one (B, weights, fuel_cost), set up once, solved often.

    u = argmin ||W (B u - w)||^2 s.t. 0 <= u <= 1 (paper 003 eq. 14), then, among all such u,
    the least fuel_cost . u; among those, the least c2 . u with c2_k = sqrt(p_k) (p_k the k-th
    prime), a fixed generic weighting that only makes the answer unique, so it does not depend
    on solver internals or call history. The fuel is never traded for c2 (lexicographic).

    Set-up (once): W B = U S V^T (SVD, rank r); W B u = y <=> A u = S^-1 U^T y with A = V_r^T
    (orthonormal rows). The fuel problem min c.u s.t. A u = b, 0 <= u <= 1 is an LP whose
    optimal vertices are given by bases: r independent columns S of A, the other levels at 0 or
    1. A basis is optimal for b iff it is primal feasible (its basic levels
    A_S^-1 (b - A_N u_N) lie in [0, 1]) and dual feasible (each nonbasic level sits at the bound
    its reduced cost d = c - A^T A_S^-T c_S points to). Dual feasibility does not depend on b,
    so all C(n, r) column subsets are enumerated here and each nonsingular one keeps the single
    bound pattern that makes it (lexicographically, fuel then c2) dual feasible. rcs_cube_12
    gives 64 bases, planar_8 32.

    Per call:
    1. b = S^-1 U^T W w. All bases' basic levels in one matrix product; the basis with the
       largest box slack, if that slack is >= -1e-10, is optimal: W B u equals the reachable
       part of W w to round-off (a feasible wrench is reproduced exactly, and the projection
       onto range(W B) is the least-squares optimum) and u is fuel-minimal. No solver runs.
    2. Otherwise w is infeasible: a primal active-set box least-squares solve (Lawson-Hanson
       style: start at a box vertex, only release a bound whose multiplier has the wrong sign
       at a subspace minimiser, so the free columns stay independent; it stops when the KKT
       conditions hold to 1e-11 relative, typically after 1-5 passes) gives the optimal
       wrench y* = W B u1 (unique even when u1 is not), then step 1 on b* = A u1 picks the
       fuel-minimal u on the optimal face.
    Whatever the stage-2 route cannot certify (enumeration too large, the active-set iteration
    cap, no optimal basis found) goes to `allocate_duty_reference`, counted in
    `fallback_count`.
    """

    def __init__(
        self,
        B: np.ndarray,
        weights: np.ndarray | None = None,
        fuel_cost: np.ndarray | None = None,
        *,
        max_bases: int = MAX_ENUMERATED_BASES,
    ):
        """Factors W B and enumerates the optimal bases.

        Args:
            B: Effectiveness matrix (m, n), e.g. `wrench_matrix(layout)`.
            weights: Diagonal of W (m,), each >= 0, not all 0 (None: all ones).
            fuel_cost: Cost of each unit of u_k (n,), > 0 (None: all ones; pass
                `layout.max_mass_flows_kg_s` for propellant mass).
            max_bases: Largest C(n, rank) enumerated (else the reference path is used).

        Raises:
            ValueError: On a non-finite or non-2-D B, bad weights or bad fuel_cost.
        """
        B = np.array(B, dtype=float)
        if B.ndim != 2 or B.shape[1] == 0 or not np.all(np.isfinite(B)):
            raise ValueError(f"B must be a finite (m, n) matrix with n >= 1, got shape {B.shape}")
        self.m, self.n = B.shape
        self._B = B
        self._weights = None if weights is None else _validated_weights(weights, self.m)
        W = _validated_weights(weights, self.m)
        self._fuel_cost = None if fuel_cost is None else _validated_fuel_cost(fuel_cost, self.n)
        c = _validated_fuel_cost(fuel_cost, self.n)
        self.fallback_count = 0
        """Calls answered by `allocate_duty_reference` (0 on the presets in practice)."""

        Bw = W[:, None] * B
        U, s, Vt = np.linalg.svd(Bw, full_matrices=False)
        r = int(np.sum(s > s[0] * 1e-12)) if s.size and s[0] > 0 else 0
        self.rank = r
        self._basis_columns = None
        if r == 0:
            return
        self._T = U[:, :r].T * W  # t = U_r^T W w: the reachable part of W w, in r coordinates
        self._inv_s = 1.0 / s[:r]
        self._A = Vt[:r]  # W B u = U_r S_r A u
        self._M = s[:r, None] * self._A  # ||W B u - W w||^2 = ||M u - t||^2 + const
        self._gram = self._M.T @ self._M  # = (W B)^T W B
        self._free_set_cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self._max_ls_iterations = 10 * self.n + 10
        self._c = c / np.max(c)  # scale-free reduced costs (mass flows are ~1e-3 kg/s)
        c2 = np.sqrt(_first_primes(self.n))
        self._c2 = c2 / np.max(c2)
        if math.comb(self.n, r) <= max_bases:
            self._enumerate_bases()

    @property
    def basis_count(self) -> int:
        """Number of enumerated optimal bases (0 when the reference path is used)."""
        return 0 if self._basis_columns is None else len(self._basis_columns)

    def _enumerate_bases(self) -> None:
        A, n, r = self._A, self.n, self.rank
        cols = np.array(list(itertools.combinations(range(n), r)), dtype=np.intp)
        mats = np.transpose(A[:, cols], (1, 0, 2))  # (K, r, r): A restricted to each subset
        smallest = np.linalg.svd(mats, compute_uv=False)[:, -1]
        keep = smallest > _MIN_BASIS_SINGULAR_VALUE
        cols, mats = cols[keep], mats[keep]
        inv = np.linalg.inv(mats)
        # Reduced costs d = c - A^T y, y = A_S^-T c_S, of the fuel (d1) and tie-break (d2) costs.
        d1 = self._c - np.einsum("kji,kj->ki", inv, self._c[cols]) @ A
        d2 = self._c2 - np.einsum("kji,kj->ki", inv, self._c2[cols]) @ A
        nonbasic = np.ones((len(cols), n), dtype=bool)
        nonbasic[np.arange(len(cols))[:, None], cols] = False
        tie = np.abs(d1) <= _TIE_TOL
        # A nonbasic level sits at 1 iff raising it lowers the (lexicographic) cost.
        upper = nonbasic & np.where(tie, d2 < 0.0, d1 < 0.0)
        ambiguous = nonbasic & tie & (np.abs(d2) <= _TIE_TOL)
        if np.any(ambiguous):  # both bounds are optimal: keep both patterns
            rows, patterns = [], []
            for k in range(len(cols)):
                free_bits = np.flatnonzero(ambiguous[k])
                for bits in itertools.product((False, True), repeat=free_bits.size):
                    pattern = upper[k].copy()
                    pattern[free_bits] = bits
                    rows.append(k)
                    patterns.append(pattern)
            cols, inv, upper = cols[rows], inv[rows], np.array(patterns)
        levels = upper.astype(float)  # nonbasic levels (0 or 1); 0 on the basic columns
        K = len(cols)
        self._basis_columns = cols
        self._basis_levels = levels
        self._basis_inverse_rows = inv.reshape(K * r, r)
        # Basic levels = A_S^-1 (b - A levels) = A_S^-1 b + offset.
        self._basis_offset = -np.einsum("kij,kj->ki", inv, levels @ A.T)

    def _fuel_minimal(self, b: np.ndarray) -> np.ndarray | None:
        """Lexicographically fuel-minimal u with A u = b, 0 <= u <= 1; None if infeasible."""
        K, r = self._basis_offset.shape
        basic = (self._basis_inverse_rows @ b).reshape(K, r)
        basic += self._basis_offset
        slack = np.minimum(basic, 1.0 - basic).min(axis=1)
        k = int(np.argmax(slack))
        if slack[k] < -_BOX_SLACK_TOL:
            return None
        u = self._basis_levels[k].copy()
        u[self._basis_columns[k]] = np.clip(basic[k], 0.0, 1.0)
        return u

    def _box_least_squares(self, t: np.ndarray) -> np.ndarray | None:
        """argmin ||M u - t|| s.t. 0 <= u <= 1 by a primal active-set method; None when the
        iteration cap is reached.

        Deterministic: starts with every level fixed at the box vertex u_k = [(M^T t)_k > 0]
        (the reachable wrench furthest along W w, near the optimum for a far-off w). Each pass
        either minimises over the free levels (normal equations on the free columns,
        independent by construction; cached inverse per free set), stepping back to the box
        and fixing the first level that reaches a bound, or, at a subspace minimiser, frees
        the fixed level whose multiplier g = M^T (M u - t) has the most wrong sign. Stops
        when every multiplier has the right sign to `_KKT_TOL` of ||M^T t||.
        """
        G, h = self._gram, self._M.T @ t
        u = (h > 0.0).astype(float)  # the box vertex furthest along W w (support point)
        fixed = np.ones(self.n, dtype=bool)
        tol = _KKT_TOL * np.linalg.norm(h)
        for _ in range(self._max_ls_iterations):
            g = G @ u - h
            free, G_free_inv = self._free_set(fixed)
            if free.size:
                u_free = u[free]
                step = G_free_inv @ -g[free]
                target = u_free + step
                if target.min() < 0.0 or target.max() > 1.0:
                    # Largest step keeping the box; fix the first level to reach a bound.
                    ratio = np.full(free.size, np.inf)
                    room = np.where(step < 0.0, -u_free, 1.0 - u_free)
                    np.divide(room, step, out=ratio, where=step != 0.0)
                    i = int(np.argmin(ratio))
                    u[free] = np.clip(u_free + max(ratio[i], 0.0) * step, 0.0, 1.0)
                    u[free[i]] = 1.0 if step[i] > 0.0 else 0.0
                    fixed[free[i]] = True
                    continue
                u[free] = target
                g = G @ u - h
            # Subspace minimiser: check the multipliers of the fixed levels.
            violation = np.where(u >= 1.0, g, -g)
            violation[~fixed] = 0.0
            j = int(np.argmax(violation))
            if violation[j] <= tol:
                return u
            fixed[j] = False
        return None

    def _free_set(self, fixed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Indices of the free levels and the (pseudo-)inverse of their Gram matrix, cached
        per free set (a pure function of it; at most sum_k C(n, k), k <= rank, sets occur)."""
        key = fixed.tobytes()
        entry = self._free_set_cache.get(key)
        if entry is None:
            free = np.flatnonzero(~fixed)
            G_free = self._gram[np.ix_(free, free)]
            try:
                G_free_inv = np.linalg.inv(G_free)
            except np.linalg.LinAlgError:
                G_free_inv = np.linalg.pinv(G_free)
            if len(self._free_set_cache) >= _FREE_SET_CACHE_SIZE:
                self._free_set_cache.clear()
            entry = self._free_set_cache[key] = (free, G_free_inv)
        return entry

    def _reference(self, w: np.ndarray, minimize_fuel: bool) -> np.ndarray:
        self.fallback_count += 1
        return allocate_duty_reference(
            self._B, w, self._weights, minimize_fuel=minimize_fuel, fuel_cost=self._fuel_cost
        )

    def solve(self, w: np.ndarray, minimize_fuel: bool = True) -> np.ndarray:
        """Duty levels for the desired wrench w (m,); see the class docstring.

        Args:
            w: Desired wrench (m,). Non-finite: returns zeros.
            minimize_fuel: Run the fuel tie-break. Without it, returns the (deterministic)
                active-set least-squares solution, optimal but not fuel-minimal.

        Returns:
            u (n,) with every entry in [0, 1].
        """
        w = np.asarray(w, dtype=float).reshape(self.m)
        # A non-finite entry makes the sum non-finite (a finite sum proves all are finite).
        if self.rank == 0 or not (math.isfinite(w.sum()) or np.all(np.isfinite(w))):
            return np.zeros(self.n)
        t = self._T @ w
        if minimize_fuel:
            if self._basis_columns is None:
                return self._reference(w, minimize_fuel)
            u = self._fuel_minimal(t * self._inv_s)
            if u is not None:
                return u  # reachable: exact and fuel-minimal
        u1 = self._box_least_squares(t)
        if u1 is None:
            return self._reference(w, minimize_fuel)
        if not minimize_fuel:
            return u1
        u2 = self._fuel_minimal(self._A @ u1)  # the optimal face W B u = W B u1
        if u2 is None:
            return self._reference(w, minimize_fuel)
        r1 = np.linalg.norm(self._M @ u1 - t)
        r2 = np.linalg.norm(self._M @ u2 - t)
        if r2 > r1 + 1e-12 * (np.linalg.norm(t) + r1):
            return self._reference(w, minimize_fuel)
        return u2


_ALLOCATOR_CACHE: dict[tuple, DutyAllocator] = {}
_ALLOCATOR_CACHE_SIZE = 16


def _cached_allocator(
    B: np.ndarray, weights: np.ndarray | None, fuel_cost: np.ndarray | None
) -> DutyAllocator:
    """A DutyAllocator for these arrays, reused across `allocate_duty` calls (its answers do
    not depend on what it solved before)."""
    B = np.asarray(B, dtype=float)
    key = (
        B.shape,
        B.tobytes(),
        None if weights is None else np.asarray(weights, dtype=float).tobytes(),
        None if fuel_cost is None else np.asarray(fuel_cost, dtype=float).tobytes(),
    )
    allocator = _ALLOCATOR_CACHE.get(key)
    if allocator is None:
        allocator = DutyAllocator(B, weights, fuel_cost)
        if len(_ALLOCATOR_CACHE) >= _ALLOCATOR_CACHE_SIZE:
            _ALLOCATOR_CACHE.pop(next(iter(_ALLOCATOR_CACHE)))
        _ALLOCATOR_CACHE[key] = allocator
    return allocator


def allocate_duty(
    B: np.ndarray,
    w: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    minimize_fuel: bool = True,
    fuel_cost: np.ndarray | None = None,
) -> np.ndarray:
    """Duty levels u = argmin ||W (B u - w)||^2 s.t. 0 <= u <= 1 (paper 003 eq. 14).

    Lexicographic, so the tie-break never costs accuracy: first the best (weighted) fit, then,
    if minimize_fuel, the least fuel_cost . u among all allocations achieving it, then a fixed
    generic tie-break that makes u unique. A feasible wrench (w = B u for some u in the box) is
    reproduced to round-off; an infeasible one gets the (weighted) least-squares optimum. See
    `DutyAllocator` for the method (~15 us a call for a feasible wrench, ~60-90 us for an
    infeasible one, against ~1.7 ms for the scipy `allocate_duty_reference`; see
    benchmarks/bench_allocator.py); the allocator of each (B, weights, fuel_cost) is built once
    (a few ms) and reused by later calls. Hold a `DutyAllocator` directly in code called every
    step.

    Args:
        B: Effectiveness matrix (m, n), e.g. `wrench_matrix(layout)`.
        w: Desired wrench (m,).
        weights: Diagonal of W (m,), each >= 0 (None: all ones).
        minimize_fuel: Run the fuel tie-break.
        fuel_cost: Cost of each unit of u_k in the tie-break (n,), > 0 (None: all ones; pass
            `layout.max_mass_flows_kg_s` for propellant mass).

    Returns:
        u (n,) with every entry in [0, 1].
    """
    return _cached_allocator(B, weights, fuel_cost).solve(w, minimize_fuel=minimize_fuel)


def allocate_duty_reference(
    B: np.ndarray,
    w: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    minimize_fuel: bool = True,
    fuel_cost: np.ndarray | None = None,
) -> np.ndarray:
    """The scipy implementation of `allocate_duty` (~2 ms a call): reference and fallback.

    Two lexicographic stages, so the tie-break never costs accuracy:
    1. scipy.optimize.lsq_linear, method 'bvls' (an exact active-set method), tol 1e-12: the
       weighted wrench y* = W B u1 closest to W w is unique even when u1 is not.
    2. If minimize_fuel: among all u with W B u = y* and 0 <= u <= 1 (all optimal allocations),
       minimise fuel_cost . u by a HiGHS LP; its vertex is then re-solved exactly on its free
       set (least squares on the basic columns) so the equality holds to machine precision.
       The stage-2 result is kept only if its fit is as good as stage 1's (to 1e-12 relative)
       and it is cheaper; otherwise u1 is returned.
    So a feasible wrench (w = B u for some u in the box) is reproduced to round-off, and an
    infeasible one gets the (weighted) least-squares optimum. Among equally cheap allocations
    the vertex returned is HiGHS's choice (`allocate_duty` makes it unique instead).

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
    import scipy.optimize  # at use: every rpod process starts ~0.25 s sooner

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
