"""Paper 004's safe-start analysis (Secs. 8-11): the three analytical certified sets and the
backward viability kernel, on the plane of Sec. 9's starts (z_T = 0).

Owns: `SafeStartGrid` (the 300 x 300 evaluation grid and its corridor mask), the directional
erosion (eq. 13) and criterion (16) with the synchronisation bound (eq. 14) as `nominal_erosion`,
`GridSlack` (the parts that do not depend on omega_t and a_max, once per grid) and
`certified_mask`, the chance and support-function tightenings (Sec. 8.3, `NoiseModel`,
`accumulated_tightenings`, `corridor_tightenings`), `certified_sets` (X_nom, X_stoch, X_rob),
the backward kernel (Sec. 10.2) as the exact polygon of a projected polyhedron
(`kernel_lp`, `support_polygon`, `backward_kernel_polygon`), the double integrator of Sec. 8.4
(eq. 17), and the paper's numbers (`PAPER_TABLE_2`, `PAPER_NUMBERS`) for the side-by-side.
Does not own: the corridor (rpod.models.los_corridor), the CW and body-frame models
(rpod.models.cw, rpod.planners.los_prediction), the Monte Carlo set X_MC (closed-loop runs,
rpod.scenarios), the tables and figures (benchmarks/bench_reachability.py,
rpod.diagrams.controllers.los_corridor.reachability_figures).

Every choice the paper leaves open, as made here (measured in
benchmarks/results/reachability.md):

1. The grid. 300 x 300 cell centres on z_T = 0 over x_T in [-tan(alpha_c) y_max, +tan(alpha_c)
   y_max], y_T in [0, y_max], y_max = 320 m. The paper does not give the extent: 320 m
   reproduces all 20 entries of Table 2 to within 0.2 pp (rms 0.07 pp); 300 m, Sec. 9's far edge,
   gives up to 4.5 pp more. Cell centres never fall on a face, so the cone (the points with
   A_c p <= b_c) is exactly half the grid, 45,000 points, and "the safe fraction of the cone" is
   the percentage of those 45,000 that a set keeps (`safe_fraction`).
2. Eq. 13 as printed. The rows a_i are eq. 9's (`LosCorridor.A_c`), unnormalised: a face's row
   [cos theta_i, -tan alpha_c, sin theta_i] has norm 1/cos(alpha_c) = 1.155, the floor's 1. The
   slack is s_i = b_i - a_i^T p, v_rot = [omega_t y_T, -omega_t x_T, 0] (the velocity in T of a
   chaser at rest in I, omega_t the inertial spin of eq. 2), ds_i = -a_i^T v_rot and delta_i =
   min(0, ds_i)^2 / (2 a_max). With the printed rows delta is not a distance: on a face the
   criterion is that of unit rows with a_max cos(alpha_c) as the braking authority. The printed
   rows reproduce Table 2, unit rows do not (`unit_rows=True`: up to 4.4 pp more, rms 1.7).
3. Criterion (16) with eq. 14: a start p is in X_nom when s_i - delta_i - Delta_i > 0 on all nine
   rows (Delta_i = 0) and |p_T| < r_sync = 2 a_max / omega_t^2. X_stoch and X_rob add Delta_i.
4. The flat spin. The target spins at omega_t (inertial, eq. 2) about its body z, which is the
   orbit normal z_L, and T coincides with L at t = 0 (eq. 10 at t = 0; `phase0_rad` moves it), so
   R_LT(t) = R_z(phase0 + (omega_t - n) t). The body-frame model is CW in L carried into T step by
   step (`cw_body_frame_matrices`): linear, periodic time-varying (CW's in-plane gravity
   gradient is anisotropic, and an input or disturbance held in L turns in T). z decouples.
5. The stochastic set's noise: white Gaussian acceleration noise N(0, sigma_a^2 I_3) in L,
   independent per step and held over it like the input (it enters through B_d), sigma_a =
   2 mm/s^2 (1 % of the largest a_max). Accumulated over N = 20 steps of 1 s through the model of
   4: sigma_i^2 = sum_{j<N} a_i^T Phi(N, j+1) B_j W B_j^T Phi(N, j+1)^T a_i with Phi(N, m) =
   A_{N-1} ... A_m (the paper's sum_j a_i^T A^j W A^jT a_i, for a time-varying A), and Delta_i
   = z sigma_i, z = Phi^-1(1 - alpha / n_c) = 2.539 (alpha = 0.05, Bonferroni over n_c = 9).
6. The robust set's W: the box |w|_inf <= w_max in L, held over each step like the input,
   w_max = 6 mm/s^2 = 3 sigma_a; Delta_i = sum_{j<N} h_W(B_j^T Phi(N, j+1)^T a_i) = w_max
   sum_j |B_j^T Phi(N, j+1)^T a_i|_1. Since sum_j |c_j|_1 >= (sum_j |c_j|_2^2)^(1/2), w_max >= z
   sigma_a makes Delta_rob >= Delta_stoch row by row, hence X_rob within X_stoch; a NoiseModel
   below that bound is refused.
7. The backward kernel (Sec. 10.2). A start p on z_T = 0 is in it when inputs u_0..u_{N-1}, N =
   N_back = 20, dt = 1 s, in the box |u_L|_inf <= a_max of eq. 11e (held in L, as the MPC applies
   it, so the box turns in T) keep A_c p_j <= b_c for j = 0..N from x_0 = (p, v_0) under the
   model of 4. No terminal set: it is a finite-horizon viability kernel, not a reach set. v_0 = 0
   by default (`start="corotating"`: Sec. 9's starts, at rest in T); `start="inertial"` takes
   v_0 = v_rot, the chaser at rest in I that eq. 13 assumes. The planar problem is exact: the
   constraints, the dynamics and the box are symmetric under z -> -z, so the mean of a feasible
   3-D trajectory and its mirror image is a feasible planar one. The kernel is cut at y_T <=
   y_max (the grid's edge); at low spin it is unbounded (a co-rotating chaser drifts outward,
   along the cone).
8. The polygon. The kernel's slice is the projection on p of a polyhedron in (p, U), a convex
   polygon; `support_polygon` finds it by support-function LPs: between two boundary points the
   LP in their edge's outward normal either certifies the edge (support value within
   `tolerance_m` of it) or returns a new boundary point. The vertices are kernel points, so
   their hull is inside the kernel; the certified edges moved out by the tolerance contain it.
   Grid points between the two are settled by one LP each, so the mask is exact at grid
   resolution (`SupportPolygon.contains`).
9. The LP solver: Drake's ClpSolver (simplex) on one MathematicalProgram per set, its cost
   and bounds updated in place: 0.2 ms a solve here against 2.3 ms for scipy's linprog (HiGHS),
   which rebuilds the problem on every call.
10. The double integrator of Sec. 8.4 (eq. 17): disturbance w_k added to the state (E = I),
   N = 5, Gaussian W = sigma_w^2 I with sigma_w = 0.02, box |w|_inf <= w_max = 0.06, alpha =
   0.05 over its n_c = 4 rows, target set |x_1| <= 1, |x_2| <= 1; the tightening of step k
   accumulates disturbances j < k and applies to the state and, at k = N, to the target set.

Units: SI (m, s, rad); omega_t in rad/s, a_max in m/s^2.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from pydrake.solvers import ClpSolver, MathematicalProgram, SolutionResult
from scipy.spatial import ConvexHull, QhullError
from scipy.stats import norm

from rpod.models.gravity import MU_EARTH_M3_S2
from rpod.models.los_corridor import LosCorridor, sync_range_m
from rpod.planners.los_prediction import TargetState, cw_body_frame_matrices

MEAN_MOTION_RAD_S = 1.131e-3  # Table 1: 500 km circular orbit
OMEGA_T_DEG_S = (1.0, 2.0, 3.0, 4.0, 5.0)  # Table 1
A_MAX_M_S2 = (0.20, 0.10, 0.05, 0.02)  # Table 1
COMBINATIONS = tuple((w, a) for w in OMEGA_T_DEG_S for a in A_MAX_M_S2)  # the 20, deg/s, m/s^2
GRID_Y_MAX_M = 320.0  # choice 1
GRID_RESOLUTION = 300  # Table 2: 300 x 300

# Paper 004 Table 2: safe fraction (%) of the cone, forward erosion (13) with r_sync (14).
PAPER_TABLE_2_ROWS = (  # rows omega_t = 1..5 deg/s; columns a_max = 0.20, 0.10, 0.05, 0.02
    (80.1, 66.6, 45.0, 7.2),
    (45.0, 11.3, 2.8, 0.4),
    (8.9, 2.2, 0.6, 0.1),
    (2.8, 0.7, 0.2, 0.0),
    (1.1, 0.3, 0.1, 0.0),
)
PAPER_TABLE_2 = dict(zip(COMBINATIONS, (v for row in PAPER_TABLE_2_ROWS for v in row)))
PAPER_NUMBERS = {
    # Sec. 10.2: (forward %, backward %) at (omega_t deg/s, a_max m/s^2).
    "forward_backward": {(1.0, 0.20): (80.1, 98.1), (3.0, 0.20): (8.9, 73.9)},
    # Sec. 11.1: (robust %, nominal %).
    "price_of_certification": {(1.0, 0.20): (75.2, 80.1)},
    # Table 4 [s], all 20 combinations.
    "table_4_s": {"nominal": 2.4, "backward": 46.0, "stochastic": 2.4, "robust": 2.2},
}

_INFEASIBLE = (SolutionResult.kInfeasibleConstraints, SolutionResult.kInfeasibleOrUnbounded)
_PLANE = [0, 1, 3, 4]  # x, y, vx, vy of the 6-state [p_T, v_T]
_CROSS_Z = np.array([[0.0, 1.0], [-1.0, 0.0]])  # v_rot = omega_t _CROSS_Z p (eq. 13's v_rot)


# --- The grid -------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False)
class SafeStartGrid:
    """The evaluation grid of Table 2 on z_T = 0 (module docstring, choice 1).

    Attributes:
        x_m: Cell-centre x_T values (n,) [m].
        y_m: Cell-centre y_T values (n,) [m].
        points_T: All grid points (n * n, 3) in T [m], y_T outer, x_T inner, z_T = 0.
        inside: (n * n,) the points in the corridor (A_c p <= b_c).
        y_max_m: The far edge y_max [m].
    """

    x_m: np.ndarray
    y_m: np.ndarray
    points_T: np.ndarray
    inside: np.ndarray
    y_max_m: float

    @classmethod
    def at_points(cls, points_T: np.ndarray, corridor: LosCorridor) -> SafeStartGrid:
        """Arbitrary points (K, 3) as a grid, so that criterion (16) can be asked at them."""
        points_T = np.asarray(points_T, dtype=float)
        empty = np.zeros(0)
        return cls(empty, empty, points_T, corridor.contains(points_T), math.nan)

    @classmethod
    def over_cone(
        cls,
        corridor: LosCorridor,
        y_max_m: float = GRID_Y_MAX_M,
        resolution: int = GRID_RESOLUTION,
    ) -> SafeStartGrid:
        """The resolution x resolution cell-centred grid over the cone's section up to y_max."""
        if not y_max_m > corridor.floor_m:
            raise ValueError(f"y_max_m must exceed the floor {corridor.floor_m}, got {y_max_m}")
        half_width = math.tan(corridor.half_angle_rad) * y_max_m
        centres = (np.arange(resolution) + 0.5) / resolution
        x = -half_width + 2.0 * half_width * centres
        y = y_max_m * centres
        X, Y = np.meshgrid(x, y)
        points = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
        return cls(x, y, points, corridor.contains(points), float(y_max_m))

    @property
    def cell_area_m2(self) -> float:
        return float((self.x_m[1] - self.x_m[0]) * (self.y_m[1] - self.y_m[0]))


def safe_fraction(mask: np.ndarray, grid: SafeStartGrid) -> float:
    """The safe fraction of the cone (%): the share of the grid's in-corridor points in mask."""
    return 100.0 * np.count_nonzero(mask & grid.inside) / np.count_nonzero(grid.inside)


# --- Eq. 13, eq. 14 and criterion (16) ------------------------------------------------------


def _rows(corridor: LosCorridor, unit_rows: bool) -> tuple[np.ndarray, np.ndarray]:
    """(A, b): eq. 9's rows as printed, or each divided by its norm."""
    A, b = corridor.A_c, corridor.b_c
    if not unit_rows:
        return A, b
    scale = np.linalg.norm(A, axis=1)
    return A / scale[:, None], b / scale


def rotation_velocity(points_T: np.ndarray, omega_t: float) -> np.ndarray:
    """v_rot = [omega_t y_T, -omega_t x_T, 0] (Sec. 8.1): the velocity in T of a chaser at rest in
    I, for a spin omega_t about z_T; (K, 3) for points (K, 3)."""
    p = np.asarray(points_T, dtype=float)
    return omega_t * np.column_stack([p[:, 1], -p[:, 0], np.zeros(len(p))])


def nominal_erosion(
    points_T: np.ndarray,
    corridor: LosCorridor,
    omega_t: float,
    a_max: float,
    unit_rows: bool = False,
) -> np.ndarray:
    """delta (K, n_c) [m for unit rows]: the directional per-constraint erosion of eq. 13.

    Args:
        points_T: Starts (K, 3) in T [m].
        corridor: The corridor whose rows a_i are eroded.
        omega_t: Spin rate about z_T [rad/s].
        a_max: Braking authority [m/s^2].
        unit_rows: Normalise the rows first (module docstring, choice 2).
    """
    if not a_max > 0.0:
        raise ValueError(f"a_max must be positive, got {a_max}")
    A, _ = _rows(corridor, unit_rows)
    slack_rate = -rotation_velocity(points_T, omega_t) @ A.T  # eq. 13: ds_i = -a_i^T v_rot
    return np.minimum(slack_rate, 0.0) ** 2 / (2.0 * a_max)  # eq. 13: (ds_i^-)^2 / (2 a_max)


@dataclasses.dataclass(frozen=True, eq=False)
class GridSlack:
    """The parts of criterion (16) that do not depend on (omega_t, a_max), at a grid's corridor
    points, rows first (n_c, K_in) so that each row is one contiguous pass.

    Attributes:
        grid: The grid.
        corridor: The corridor.
        unit_rows: Rows normalised (choice 2).
        index: (K_in,) the corridor points' indices in the grid.
        slack: (n_c, K_in) s_i = b_i - a_i^T p.
        rate_per_omega: (n_c, K_in) ds_i / omega_t = -a_i^T v_rot / omega_t (eq. 13).
        range_m: (K_in,) |p_T| (eq. 14).
    """

    grid: SafeStartGrid
    corridor: LosCorridor
    unit_rows: bool
    index: np.ndarray
    slack: np.ndarray
    rate_per_omega: np.ndarray
    range_m: np.ndarray

    @classmethod
    def on(cls, grid: SafeStartGrid, corridor: LosCorridor, unit_rows: bool = False) -> GridSlack:
        A, b = _rows(corridor, unit_rows)
        index = np.flatnonzero(grid.inside)
        p = grid.points_T[index]
        slack = np.ascontiguousarray((b - p @ A.T).T)
        rate = np.ascontiguousarray((-rotation_velocity(p, 1.0) @ A.T).T)
        return cls(grid, corridor, unit_rows, index, slack, rate, np.linalg.norm(p, axis=1))


def certified_mask(
    terms: GridSlack, omega_t: float, a_max: float, tightening: np.ndarray | float = 0.0
) -> np.ndarray:
    """(K,) bool on the grid: criterion (16), s_i - delta_i - Delta_i > 0 on every row, and |p| <
    r_sync (eq. 14), at each corridor point (False elsewhere).

    Args:
        terms: The grid's slack and slack rates (`GridSlack.on`).
        omega_t: Spin rate about z_T [rad/s].
        a_max: Braking authority [m/s^2].
        tightening: Delta_i, (n_c,) or a scalar (rows' units); 0 gives X_nom.
    """
    if not a_max > 0.0:
        raise ValueError(f"a_max must be positive, got {a_max}")
    tightening = np.broadcast_to(np.asarray(tightening, dtype=float), (len(terms.slack),))
    keep = terms.range_m < sync_range_m(a_max, omega_t)  # eq. 14
    scale = omega_t**2 / (2.0 * a_max)  # eq. 13: delta_i = (omega_t rate_i^-)^2 / (2 a_max)
    sign = 1.0 if omega_t >= 0.0 else -1.0  # min(0, omega_t r) = |omega_t| min(0, sign r)
    for slack, rate, delta_extra in zip(terms.slack, terms.rate_per_omega, tightening):
        negative = np.minimum(sign * rate, 0.0)
        keep &= slack - scale * negative * negative > delta_extra  # eq. 16
    mask = np.zeros(len(terms.grid.points_T), dtype=bool)
    mask[terms.index[keep]] = True
    return mask


# --- The flat spin's body-frame model and the tightenings -----------------------------------


def flat_spin_targets(
    omega_t: float, n: float, steps: int, dt: float, phase0_rad: float = 0.0
) -> list[TargetState]:
    """The target at t_k = k dt, k = 0..steps, on a circular orbit of mean motion n, spinning at
    omega_t (inertial) about its body z = the orbit normal; T = R_z(phase0) L at t = 0."""
    radius = (MU_EARTH_M3_S2 / n**2) ** (1.0 / 3.0)
    targets = []
    for k in range(steps + 1):
        t = k * dt
        c, s = math.cos(n * t), math.sin(n * t)
        angle = phase0_rad + omega_t * t  # R_IT = R_IL R_LT = R_z(n t) R_z(phase0 + (w - n) t)
        ca, sa = math.cos(angle), math.sin(angle)
        R_IT = np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
        targets.append(
            TargetState(
                radius * np.array([c, s, 0.0]),
                radius * n * np.array([-s, c, 0.0]),
                R_IT,
                np.array([0.0, 0.0, omega_t]),
            )
        )
    return targets


def flat_spin_body_model(
    omega_t: float, n: float, steps: int, dt: float, phase0_rad: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """(A (steps, 6, 6), B (steps, 6, 3)): x_{k+1} = A_k x_k + B_k u_L,k for x = [p_T, v_T]
    (choice 4): CW (eqs. 5-6) carried into the spinning body frame at every step."""
    targets = flat_spin_targets(omega_t, n, steps, dt, phase0_rad)
    pairs = [cw_body_frame_matrices(n, dt, targets[k], targets[k + 1]) for k in range(steps)]
    return np.array([A for A, _ in pairs]), np.array([B for _, B in pairs])


def bonferroni_quantile(alpha: float, n_constraints: int) -> float:
    """z_{1 - alpha / n_c} (Sec. 8.3)."""
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    return float(norm.ppf(1.0 - alpha / n_constraints))


def accumulated_tightenings(
    rows: np.ndarray,
    A_steps: np.ndarray,
    E_steps: np.ndarray,
    sigma_w: float,
    w_max: float,
    alpha: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(stochastic (N + 1, n_c), robust (N + 1, n_c)): Delta at each step k = 0..N.

    x_{k+1} = A_k x_k + E_k w_k with w_k ~ N(0, sigma_w^2 I) for the first and |w_k|_inf <=
    w_max for the second; with c_kj = E_j^T Phi(k, j+1)^T r_i (Phi(k, m) = A_{k-1} ... A_m):

        stochastic: z_{1-alpha/n_c} sigma_w (sum_{j<k} |c_kj|_2^2)^(1/2)   (Sec. 8.3, item 3)
        robust:     w_max sum_{j<k} |c_kj|_1 = sum_j h_W(c_kj)               (Sec. 8.3, item 4)

    Args:
        rows: r_i (n_c, nx), the constraint rows on the state.
        A_steps: (N, nx, nx), or (nx, nx) repeated (then E_steps fixes N).
        E_steps: (N, nx, nw), or (nx, nw) repeated.
    """
    rows = np.asarray(rows, dtype=float)
    A_steps, E_steps = np.asarray(A_steps, dtype=float), np.asarray(E_steps, dtype=float)
    steps = len(A_steps) if A_steps.ndim == 3 else len(E_steps) if E_steps.ndim == 3 else None
    if steps is None:
        raise ValueError("give A_steps or E_steps per step (a leading axis N)")
    if A_steps.ndim == 2:
        A_steps = np.broadcast_to(A_steps, (steps,) + A_steps.shape)
    if E_steps.ndim == 2:
        E_steps = np.broadcast_to(E_steps, (steps,) + E_steps.shape)
    z = bonferroni_quantile(alpha, len(rows))
    sum_sq = np.zeros((steps + 1, len(rows)))
    sum_l1 = np.zeros((steps + 1, len(rows)))
    responses = np.zeros((0,) + E_steps.shape[1:])  # Phi(k, j+1) E_j for j < k
    for k in range(steps):
        responses = np.concatenate([A_steps[k] @ responses, E_steps[k][None]])  # now k + 1
        c = np.einsum("ix,jxw->ijw", rows, responses)  # c_{k+1, j} (n_c, k + 1, nw)
        sum_sq[k + 1] = np.sum(c**2, axis=(1, 2))
        sum_l1[k + 1] = np.sum(np.abs(c), axis=(1, 2))
    return z * sigma_w * np.sqrt(sum_sq), w_max * sum_l1


@dataclasses.dataclass(frozen=True)
class NoiseModel:
    """The disturbances of X_stoch and X_rob (choices 5-6).

    Attributes:
        sigma_m_s2: sigma_a, the Gaussian acceleration noise per axis of L, per step [m/s^2].
        w_max_m_s2: The box W: |w|_inf <= w_max per step, in L [m/s^2].
        alpha: The chance constraints' total violation probability (Bonferroni over rows).
        steps: N, the analysis horizon [steps].
        dt_s: The step [s].
    """

    sigma_m_s2: float = 2e-3
    w_max_m_s2: float = 6e-3
    alpha: float = 0.05
    steps: int = 20
    dt_s: float = 1.0

    def __post_init__(self):
        if self.sigma_m_s2 < 0.0 or self.w_max_m_s2 < 0.0:
            raise ValueError("sigma_m_s2 and w_max_m_s2 must be non-negative")
        if self.steps < 1 or not self.dt_s > 0.0:
            raise ValueError("steps must be >= 1 and dt_s positive")


def corridor_tightenings(
    corridor: LosCorridor,
    omega_t: float,
    noise: NoiseModel,
    n: float = MEAN_MOTION_RAD_S,
    unit_rows: bool = False,
    phase0_rad: float = 0.0,
) -> dict[str, np.ndarray]:
    """{"stochastic": (n_c,), "robust": (n_c,)}: Delta_i after noise.steps steps of the flat
    spin's model (choices 4-6), the input matrices B_k carrying the disturbance held in L."""
    A, _ = _rows(corridor, unit_rows)
    z = bonferroni_quantile(noise.alpha, len(A))
    if noise.w_max_m_s2 < z * noise.sigma_m_s2:
        raise ValueError(
            f"w_max_m_s2 = {noise.w_max_m_s2} is below z sigma = {z * noise.sigma_m_s2:.3g}: "
            "X_rob within X_stoch is then not guaranteed (module docstring, choice 6)"
        )
    A_steps, B_steps = flat_spin_body_model(omega_t, n, noise.steps, noise.dt_s, phase0_rad)
    rows = np.hstack([A, np.zeros_like(A)])  # a_i on p_T, nothing on v_T
    stochastic, robust = accumulated_tightenings(
        rows, A_steps, B_steps, noise.sigma_m_s2, noise.w_max_m_s2, noise.alpha
    )
    return {"stochastic": stochastic[-1], "robust": robust[-1]}


def certified_sets(
    terms: GridSlack,
    omega_t: float,
    a_max: float,
    noise: NoiseModel | None = None,
    n: float = MEAN_MOTION_RAD_S,
) -> dict[str, np.ndarray]:
    """{"nominal", "stochastic", "robust"}: (K,) bool masks of X_nom, X_stoch, X_rob on the grid
    (criterion 16 with eq. 14; choices 2-6), nested by construction (Delta_rob >= Delta_stoch >=
    0)."""
    noise = NoiseModel() if noise is None else noise
    tight = corridor_tightenings(terms.corridor, omega_t, noise, n, terms.unit_rows)
    return {
        "nominal": certified_mask(terms, omega_t, a_max),
        "stochastic": certified_mask(terms, omega_t, a_max, tight["stochastic"]),
        "robust": certified_mask(terms, omega_t, a_max, tight["robust"]),
    }


# --- Projected polyhedra and their polygons -------------------------------------------------


class ProjectionLp:
    """The set P = {p in R^2 : exists U with |U|_inf <= u_max and F p + H U <= g}, and its two
    LPs (Drake's ClpSolver on one program, cost and bounds updated in place; choice 9).

    Args:
        F: (m, 2).
        H: (m, n_u).
        g: (m,).
        u_max: The box on U.
    """

    def __init__(self, F: np.ndarray, H: np.ndarray, g: np.ndarray, u_max: float):
        self.F = np.asarray(F, dtype=float)
        self.H = np.asarray(H, dtype=float)
        self.g = np.asarray(g, dtype=float)
        self.u_max = float(u_max)
        self.solves = 0
        prog = MathematicalProgram()
        self._p = prog.NewContinuousVariables(2, "p")
        self._U = prog.NewContinuousVariables(self.H.shape[1], "U")
        prog.AddLinearConstraint(
            np.hstack([self.F, self.H]),
            np.full(len(self.g), -np.inf),
            self.g,
            np.concatenate([self._p, self._U]),
        )
        prog.AddBoundingBoxConstraint(-self.u_max, self.u_max, self._U)
        self._p_box = prog.AddBoundingBoxConstraint(-np.inf, np.inf, self._p)
        self._cost = prog.AddLinearCost(np.zeros(2), 0.0, self._p)
        self._prog = prog
        self._solver = ClpSolver()

    def support(self, direction) -> tuple[float, np.ndarray]:
        """(h_P(d), a maximiser p): max d^T p over P. Raises ValueError when P is empty or
        unbounded in d."""
        d = np.asarray(direction, dtype=float)
        self._p_box.evaluator().set_bounds(np.full(2, -np.inf), np.full(2, np.inf))
        self._cost.evaluator().UpdateCoefficients(-d, 0.0)
        result = self._solve()
        if not result.is_success():
            raise ValueError(f"support LP in direction {d}: {result.get_solution_result()}")
        p = result.GetSolution(self._p)
        return float(d @ p), p

    def feasible(self, p) -> tuple[bool, np.ndarray | None]:
        """(p in P, a U that shows it or None): the LP with p fixed and no cost."""
        p = np.asarray(p, dtype=float)
        self._p_box.evaluator().set_bounds(p, p)
        self._cost.evaluator().UpdateCoefficients(np.zeros(2), 0.0)
        result = self._solve()
        if result.is_success():
            return True, result.GetSolution(self._U)
        if result.get_solution_result() not in _INFEASIBLE:  # U is bounded: never unbounded
            raise RuntimeError(f"feasibility LP at {p}: {result.get_solution_result()}")
        return False, None

    def is_empty(self) -> bool:
        """P is empty: the LP with p free and no cost is infeasible."""
        self._p_box.evaluator().set_bounds(np.full(2, -np.inf), np.full(2, np.inf))
        self._cost.evaluator().UpdateCoefficients(np.zeros(2), 0.0)
        result = self._solve()
        if result.is_success():
            return False
        if result.get_solution_result() not in _INFEASIBLE:  # no cost: never unbounded
            raise RuntimeError(f"emptiness LP: {result.get_solution_result()}")
        return True

    def _solve(self):
        self.solves += 1
        return self._solver.Solve(self._prog)


def in_polygon(points_xy: np.ndarray, vertices: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """(K,) bool: points within `margin` [m] outside the convex polygon or inside it (vertices
    counter-clockwise; one or two vertices: a point or a segment)."""
    return _signed_distance(points_xy, vertices) >= -margin


def _signed_distance(points_xy: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """(K,): min over edges of the distance inside each edge's line (positive inside a CCW convex
    polygon); minus the distance to the hull for a point or segment, -inf for no vertices."""
    q = np.asarray(points_xy, dtype=float)[:, :2]
    V = np.asarray(vertices, dtype=float)
    if len(V) == 0:
        return np.full(len(q), -np.inf)
    if len(V) == 1:
        return -np.linalg.norm(q - V[0], axis=1)
    if len(V) == 2:
        e = V[1] - V[0]
        t = np.clip((q - V[0]) @ e / (e @ e), 0.0, 1.0)
        return -np.linalg.norm(q - (V[0] + t[:, None] * e), axis=1)
    edges = np.roll(V, -1, axis=0) - V
    lengths = np.linalg.norm(edges, axis=1)
    rel = q[:, None, :] - V[None, :, :]
    cross = edges[None, :, 0] * rel[:, :, 1] - edges[None, :, 1] * rel[:, :, 0]
    return np.min(cross / lengths[None, :], axis=1)


@dataclasses.dataclass(frozen=True, eq=False)
class SupportPolygon:
    """A convex set's polygon from `support_polygon` (choice 8).

    Attributes:
        vertices: (V, 2) counter-clockwise, each a point of the set (their hull is inside it).
        tolerance_m: Every edge moved out by this contains the set.
        lp: The set's LPs (settles the points in between).
        solves: LPs spent finding the polygon.
    """

    vertices: np.ndarray
    tolerance_m: float
    lp: ProjectionLp
    solves: int

    def band(self, points_xy: np.ndarray) -> np.ndarray:
        """(K,) bool: the points neither surely in (in the hull) nor surely out (beyond an edge
        by more than the tolerance)."""
        d = _signed_distance(points_xy, self.vertices)
        return (d < 0.0) & (d >= -self.tolerance_m)

    def contains(self, points_xy: np.ndarray) -> np.ndarray:
        """(K,) bool, exact: the hull's points, and the band's points whose LP is feasible."""
        points_xy = np.asarray(points_xy, dtype=float)[:, :2]
        d = _signed_distance(points_xy, self.vertices)
        mask = d >= 0.0
        for k in np.flatnonzero((d < 0.0) & (d >= -self.tolerance_m)):
            mask[k] = self.lp.feasible(points_xy[k])[0]
        return mask

    @property
    def area_m2(self) -> float:
        if len(self.vertices) < 3:
            return 0.0
        x, y = self.vertices[:, 0], self.vertices[:, 1]
        return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def support_polygon(
    lp: ProjectionLp,
    tolerance_m: float = 1e-4,
    initial_directions: int = 8,
    max_solves: int = 5000,
) -> SupportPolygon:
    """The polygon of a bounded projected set by support-function LPs and edge refinement
    (choice 8): each final edge is certified by one LP in its outward normal.

    Raises:
        ValueError: The set is unbounded (bound it with a row of F, g first).
        RuntimeError: max_solves LPs did not certify every edge.
    """
    start = lp.solves
    if lp.is_empty():
        return SupportPolygon(np.zeros((0, 2)), tolerance_m, lp, lp.solves - start)
    angles = 2.0 * math.pi * np.arange(initial_directions) / initial_directions
    points = [lp.support([math.cos(a), math.sin(a)])[1] for a in angles]
    boundary = []
    pending = [(points[i], points[(i + 1) % len(points)]) for i in range(len(points))][::-1]
    while pending:  # depth-first along the boundary, so `boundary` stays counter-clockwise
        a, b = pending.pop()
        edge = b - a
        length = float(np.linalg.norm(edge))
        if length <= 1e-9:
            continue
        normal = np.array([edge[1], -edge[0]]) / length  # outward for a CCW boundary
        value, p = lp.support(normal)
        if value <= normal @ a + tolerance_m:
            boundary.append(a)  # the edge a -> b is certified
        else:
            pending.extend([(p, b), (a, p)])
        if lp.solves - start > max_solves:
            raise RuntimeError(f"support_polygon: {max_solves} LPs did not certify every edge")
    if not boundary:  # every support point the same: a single point
        boundary = [points[0]]
    return SupportPolygon(_hull(np.array(boundary)), tolerance_m, lp, lp.solves - start)


def _hull(points: np.ndarray) -> np.ndarray:
    """The counter-clockwise convex hull of the points (a point or segment when degenerate)."""
    unique = np.unique(np.round(points, 12), axis=0)
    if len(unique) <= 2:
        return unique
    try:
        return unique[ConvexHull(unique).vertices]  # counter-clockwise in 2-D
    except QhullError:  # collinear: the segment's two ends
        order = np.argsort(unique @ (unique[-1] - unique[0]))
        return unique[[order[0], order[-1]]]


# --- The backward viability kernel (Sec. 10.2) ----------------------------------------------


def start_velocity_map(start: str, omega_t: float) -> np.ndarray:
    """(4, 2): x_0 = [p; v_0] from p on the plane for a start "corotating" (v_0 = 0, at rest in T)
    or "inertial" (v_0 = v_rot, at rest in I, eq. 13's premise)."""
    E = np.vstack([np.eye(2), np.zeros((2, 2))])
    if start == "inertial":
        E[2:] = omega_t * _CROSS_Z
    elif start != "corotating":
        raise ValueError(f"start must be 'corotating' or 'inertial', got {start!r}")
    return E


def kernel_lp(
    corridor: LosCorridor,
    omega_t: float,
    a_max: float,
    n: float = MEAN_MOTION_RAD_S,
    steps: int = 20,
    dt: float = 1.0,
    start: str = "corotating",
    y_max_m: float | None = GRID_Y_MAX_M,
    phase0_rad: float = 0.0,
) -> ProjectionLp:
    """The backward kernel's slice on z_T = 0 as a ProjectionLp (choice 7): p with inputs U =
    [u_L,0, ..., u_L,N-1] (x, y of each), |U|_inf <= a_max, such that A_c p_j <= b_c for j =
    0..steps, and y_T <= y_max_m (None: no cut, the set may be unbounded)."""
    if not a_max > 0.0:
        raise ValueError(f"a_max must be positive, got {a_max}")
    A6, B6 = flat_spin_body_model(omega_t, n, steps, dt, phase0_rad)
    A = A6[:, _PLANE][:, :, _PLANE]
    B = B6[:, _PLANE][:, :, :2]
    C = corridor.A_c[:, :2]  # z_T = 0 throughout (exact, choice 7)
    state_p = start_velocity_map(start, omega_t)  # x_j = state_p_j p + state_u_j U
    state_u = np.zeros((4, 2 * steps))
    F_blocks, H_blocks = [], []
    for j in range(steps + 1):
        F_blocks.append(C @ state_p[:2])  # A_c p_j <= b_c (eq. 11d, j = 0..N)
        H_blocks.append(C @ state_u[:2])
        if j < steps:
            state_p = A[j] @ state_p
            state_u = A[j] @ state_u
            state_u[:, 2 * j : 2 * j + 2] += B[j]
    F, H = np.vstack(F_blocks), np.vstack(H_blocks)
    g = np.tile(corridor.b_c, steps + 1)
    if y_max_m is not None:
        F = np.vstack([F, [0.0, 1.0]])
        H = np.vstack([H, np.zeros(2 * steps)])
        g = np.append(g, y_max_m)
    return ProjectionLp(F, H, g, a_max)


def backward_kernel_polygon(
    corridor: LosCorridor,
    omega_t: float,
    a_max: float,
    n: float = MEAN_MOTION_RAD_S,
    steps: int = 20,
    dt: float = 1.0,
    start: str = "corotating",
    y_max_m: float = GRID_Y_MAX_M,
    phase0_rad: float = 0.0,
    tolerance_m: float = 1e-4,
) -> SupportPolygon:
    """The backward kernel over `steps` steps, sliced at the grid's starts, cut at y_max (choices
    4, 7-9); `.contains(grid.points_T)` is its exact mask on a grid."""
    lp = kernel_lp(corridor, omega_t, a_max, n, steps, dt, start, y_max_m, phase0_rad)
    return support_polygon(lp, tolerance_m)


# --- Sec. 8.4: the double integrator (eq. 17) -----------------------------------------------


@dataclasses.dataclass(frozen=True)
class DoubleIntegratorExample:
    """Sec. 8.4's illustration (choice 10): x_{k+1} = A x_k + B u_k + w_k (eq. 17), |x_1| <= 5,
    |x_2| <= 3, |u| <= 1, N steps to a target box.

    Attributes:
        steps: N.
        sigma_w: Gaussian w_k ~ N(0, sigma_w^2 I).
        w_max: Box |w_k|_inf <= w_max.
        alpha: Chance constraints' violation probability (Bonferroni over the 4 rows).
        target_half_widths: The target set |x_1| <= t_1, |x_2| <= t_2 at step N.
        u_max: |u| <= u_max.
    """

    steps: int = 5
    sigma_w: float = 0.02
    w_max: float = 0.06
    alpha: float = 0.05
    target_half_widths: tuple[float, float] = (1.0, 1.0)
    u_max: float = 1.0

    A = np.array([[1.0, 1.0], [0.0, 1.0]])  # eq. 17
    B = np.array([0.5, 1.0])  # eq. 17
    rows = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    limits = np.array([5.0, 5.0, 3.0, 3.0])

    def tightenings(self) -> dict[str, np.ndarray]:
        """{"nominal", "stochastic", "robust"}: Delta (N + 1, 4) at each step, per row."""
        stochastic, robust = accumulated_tightenings(
            self.rows,
            np.broadcast_to(self.A, (self.steps, 2, 2)),
            np.eye(2),
            self.sigma_w,
            self.w_max,
            self.alpha,
        )
        return {"nominal": np.zeros_like(stochastic), "stochastic": stochastic, "robust": robust}

    def safe_start_lp(self, tightening: np.ndarray) -> ProjectionLp:
        """The starts x_0 from which an input sequence keeps rows x_k <= limits - Delta_k for k =
        0..N and reaches the target set, tightened by Delta_N, at N."""
        target = np.repeat(np.asarray(self.target_half_widths, dtype=float), 2)
        state_p, state_u = np.eye(2), np.zeros((2, self.steps))
        F_blocks, H_blocks, g_blocks = [], [], []
        for k in range(self.steps + 1):
            F_blocks.append(self.rows @ state_p)
            H_blocks.append(self.rows @ state_u)
            g_blocks.append(self.limits - tightening[k])
            if k < self.steps:
                state_p = self.A @ state_p
                state_u = self.A @ state_u
                state_u[:, k] += self.B
        F_blocks.append(self.rows @ state_p)
        H_blocks.append(self.rows @ state_u)
        g_blocks.append(target - tightening[self.steps])
        F, H, g = np.vstack(F_blocks), np.vstack(H_blocks), np.concatenate(g_blocks)
        return ProjectionLp(F, H, g, self.u_max)

    def safe_start_sets(self, tolerance: float = 1e-7) -> dict[str, SupportPolygon]:
        """{"nominal", "stochastic", "robust"}: the three safe-start polygons."""
        return {
            name: support_polygon(self.safe_start_lp(delta), tolerance)
            for name, delta in self.tightenings().items()
        }
