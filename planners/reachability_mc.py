"""Paper 004's empirical safe-start set X_MC (Secs. 9, 10.4-10.5) beside the analytical sets:
a campaign's closed-loop outcomes at the 195 starts of each (omega_t, a_max), mapped onto the
300 x 300 grid by natural-neighbour interpolation, and the check X_nom within X_MC (eq. 15).

Owns: Sibson's natural-neighbour interpolation (`sibson_weights`, `sibson_interpolate`,
`natural_neighbour_mask`), the classification of a campaign's runs (`classify_run`,
`mc_starts`, `mc_outcomes`), the Monte Carlo start set of Sec. 9 (`paper_mc_starts`) and the
comparison with the certified sets (`mc_report`: X_MC's share of the cone, the exceptions to
X_nom within X_MC and the runs behind them).
Does not own: the runs (`rpod sweep` and its store, rpod.scenarios; this module reads the
store's rows as plain dicts), the analytical sets and the grid (rpod.planners.reachability),
the figures (rpod.diagrams.controllers.los_corridor.monte_carlo_figures), the tables
(benchmarks/los_monte_carlo_report.py).

Choices, where the paper leaves them open:

1. Classification (Sec. 9, item 3). A run is feasible when it finished (status 'ok'), its
   summary reports no corridor violation deeper than 1e-3 m (`los_violation`, computed with
   that tolerance) and it flew the whole campaign duration (no `stopped_early`, and
   `sim_time_s` within 1e-6 s of the duration). Everything else is infeasible: a failed run,
   a run stopped at its first violation (`stop_at_violation`) and any other early end are the
   paper's "early termination". The duration is the longest `sim_time_s` of the campaign's
   finished runs unless given (the rows do not carry the campaign-level `duration_s`).
   "OSQP reports infeasibility" is NOT a failure here: rpod's controller flies a checked
   fallback when a QP is not solved, so only what the chaser did counts; the QP and fallback
   counts are reported beside the outcome. Contact (`min_separation_m` <= 0) is reported, not
   classified: the paper's criterion is the corridor alone. Pending runs are left out.
2. The interpolation (Sec. 9, item 4) is Sibson's, exact: a query q strictly inside the
   sites' convex hull takes w_i = A_i / sum_j A_j, A_i the area that q's Voronoi cell takes
   from site i's when q is inserted (`sibson_weights`, below). A query outside the hull, on
   it (within `tolerance` x the sites' extent) or on a site takes its nearest site's value
   (the paper's nearest-neighbour extrapolation). The interpolated outcome is thresholded at
   0.5, a tie counting as infeasible (X_MC is the set the report vouches for).
3. The grid is reachability's (`SafeStartGrid.over_cone`, y_max = 320 m, 300 x 300): X_MC's
   share is of the same 45,000 in-cone points as Table 2's. Beyond the starts' hull (y_T < 20
   m, y_T > 300 m, and the 5 % wedge at each face) X_MC is extrapolated, as in the paper.
4. The exceptions to X_nom within X_MC are counted on the grid and attributed, each grid
   point to its nearest infeasible start (the runs that pull the interpolant below 0.5); a
   start is also checked directly against criterion (16) with eq. 14 at its own position, so
   a certified start that failed in closed loop (a true counterexample) is told apart from
   the interpolation's smearing of an uncertified failure across X_nom's edge.

Sibson's areas by the Bowyer-Watson cavity (no polygon clipping): the triangles of the
sites' Delaunay triangulation whose circumcircle holds q strictly are the ones q's insertion
deletes; their corners are q's natural neighbours; their circumcentres c_T are the old
Voronoi vertices inside q's new cell. The region q takes from site p_i is the convex polygon
bounded by (a) the bisector of q and p_i between g_{i-1} and g_i, the circumcentres of the new
triangles (q, p_{i-1}, p_i) and (q, p_i, p_{i+1}), and (b) the old Voronoi edges of p_i inside
q's cell, one per cavity edge (p_i, p_j): from c_R to c_L, L and R the triangles left and
right of p_i -> p_j, a triangle outside the cavity standing in with g = circumcentre(q, p_i,
p_j) (where that Voronoi edge leaves q's cell). Its shoelace area taken about the midpoint m_i
= (q + p_i) / 2, which lies on the bisector, drops (a): 2 A_i = sum over p_i's cavity edges of
(c_R - m_i) x (c_L - m_i). Each term is local to one cavity triangle and one of its edges, so
the whole computation is a few array passes over (query, cavity triangle) pairs; an edge
inside the cavity is met from both its triangles and counts half from each.

Units: SI (m, s); omega_t in deg/s where a key says `omega_deg`, a_max in m/s^2.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.sparse import csr_matrix
from scipy.spatial import ConvexHull, Delaunay, QhullError, cKDTree

from rpod.models.frames import cross_2d
from rpod.models.los_corridor import (
    VIOLATION_TOLERANCE_M,
    LosCorridor,
    holding_range_m,
    sync_range_m,
)
from rpod.planners import reachability as reach

MC_Y_RANGE_M = (20.0, 300.0)  # Sec. 9: 15 values of y_T
MC_Y_COUNT = 15
MC_X_COUNT = 13  # Sec. 9: 13 values of x_T per y_T
MC_X_FILL = 0.95  # x_T within 0.95 tan(alpha_c) y_T
THRESHOLD = 0.5  # choice 2: feasible where the interpolated outcome exceeds this

_CHUNK = 8192  # queries per pass of the cavity search


# --- Sibson's natural-neighbour interpolation ----------------------------------------------


def _circumcentres(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(n, 2) circumcentres of the triangles (a, b, c), each (n, 2); inf/nan when degenerate."""
    b, c = b - a, c - a
    d = 2.0 * cross_2d(b, c)
    bb, cc = np.sum(b * b, axis=1), np.sum(c * c, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (c[:, 1] * bb - b[:, 1] * cc) / d
        y = (b[:, 0] * cc - c[:, 0] * bb) / d
    return a + np.column_stack([x, y])


def _ccw_triangulation(sites: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(simplices (T, 3), neighbours (T, 3)) of the Delaunay triangulation, every triangle
    counter-clockwise; neighbours[t, k] is across the edge opposite corner k (-1: none)."""
    tri = Delaunay(sites)
    simplices, neighbours = tri.simplices.copy(), tri.neighbors.copy()
    p = sites[simplices]
    clockwise = cross_2d(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]) < 0.0
    simplices[clockwise] = simplices[clockwise][:, [0, 2, 1]]
    neighbours[clockwise] = neighbours[clockwise][:, [0, 2, 1]]
    return simplices, neighbours


def _strictly_inside_hull(sites: np.ndarray, query: np.ndarray, margin: float) -> np.ndarray:
    """(M,) bool: the queries more than `margin` inside the sites' convex hull."""
    equations = ConvexHull(sites).equations  # n . x + offset <= 0 inside, n a unit normal
    return np.max(query @ equations[:, :2].T + equations[:, 2], axis=1) < -margin


def _sibson_areas(
    sites: np.ndarray,
    simplices: np.ndarray,
    neighbours: np.ndarray,
    centres: np.ndarray,
    radii2: np.ndarray,
    query: np.ndarray,
) -> np.ndarray:
    """(M, K): the area each site's Voronoi cell loses to each query (module docstring); the
    queries must be strictly inside the hull and off the sites."""
    m, k = len(query), len(sites)
    # |c_T - q|^2 < R_T^2 (the circumcircle holds q strictly), expanded into one product; a
    # query within rounding of a circle may fall either way: T's share is then ~0 either way.
    power = np.sum(centres * centres, axis=1) - radii2
    cavity = query @ (-2.0 * centres.T) + power[None, :] + np.sum(query * query, axis=1)[:, None]
    cavity = cavity < 0.0
    qi, ti = np.nonzero(cavity)
    q = query[qi]
    c_t = centres[ti] - q  # all coordinates relative to q
    twice_area = np.zeros(m * k)
    for corner in range(3):
        a = simplices[ti, corner]
        b = simplices[ti, (corner + 1) % 3]  # the edge a -> b has this triangle on its left
        r = neighbours[ti, (corner + 2) % 3]  # and r on its right
        r_in = np.zeros(len(ti), dtype=bool)
        has_r = r >= 0
        r_in[has_r] = cavity[qi[has_r], r[has_r]]
        p_a, p_b = sites[a] - q, sites[b] - q
        x_r = np.empty_like(c_t)
        x_r[r_in] = centres[r[r_in]] - q[r_in]
        out = ~r_in  # the Voronoi edge leaves q's cell at g = circumcentre(q, a, b)
        x_r[out] = _circumcentres(np.zeros((np.count_nonzero(out), 2)), p_a[out], p_b[out])
        half = np.where(r_in, 0.5, 1.0)  # an edge inside the cavity is met from both sides
        m_a, m_b = 0.5 * p_a, 0.5 * p_b  # the midpoints: on the bisectors of q and a, q and b
        # The edge a -> b seen from a: its Voronoi edge runs from c_R to c_L = c_t; from b
        # (the edge b -> a, left and right swapped): from c_t to c_R.
        twice_area += np.bincount(
            qi * k + a, weights=half * cross_2d(x_r - m_a, c_t - m_a), minlength=m * k
        )
        twice_area += np.bincount(
            qi * k + b, weights=half * cross_2d(c_t - m_b, x_r - m_b), minlength=m * k
        )
    return 0.5 * twice_area.reshape(m, k)


def sibson_weights(
    sites_xy: np.ndarray, query_xy: np.ndarray, tolerance: float = 1e-9
) -> csr_matrix:
    """(M, K) sparse: the natural-neighbour (Sibson) weights of K sites at M queries, with
    nearest-neighbour extrapolation (module docstring, choice 2): a row sums to 1; a query
    outside the sites' convex hull, within tolerance x extent of it or of a site, weighs its
    nearest site alone. Fewer than 3 sites, or collinear ones: nearest neighbour everywhere.

    Args:
        sites_xy: (K, 2) distinct sites.
        query_xy: (M, 2) queries.
        tolerance: Relative to the sites' extent (the largest coordinate range).
    """
    sites = np.asarray(sites_xy, dtype=float)[:, :2]
    query = np.asarray(query_xy, dtype=float)[:, :2]
    if len(sites) == 0:
        raise ValueError("no sites")
    if len(np.unique(sites, axis=0)) != len(sites):
        raise ValueError("the sites must be distinct")
    extent = float(np.max(np.ptp(sites, axis=0))) if len(sites) > 1 else 1.0
    margin = tolerance * max(extent, 1e-300)
    distance, nearest = cKDTree(sites).query(query)
    interior = np.zeros(len(query), dtype=bool)
    triangulation = None
    if len(sites) >= 3:
        try:
            triangulation = _ccw_triangulation(sites)
            interior = _strictly_inside_hull(sites, query, margin) & (distance > margin)
        except QhullError:  # collinear sites: no triangle, nearest neighbour everywhere
            triangulation = None
    rows = [np.flatnonzero(~interior)]
    cols = [nearest[~interior]]
    vals = [np.ones(len(rows[0]))]
    if triangulation is not None and interior.any():
        simplices, neighbours = triangulation
        p = sites[simplices]
        centres = _circumcentres(p[:, 0], p[:, 1], p[:, 2])
        radii2 = np.sum((centres - p[:, 0]) ** 2, axis=1)
        index = np.flatnonzero(interior)
        for start in range(0, len(index), _CHUNK):
            chunk = index[start : start + _CHUNK]
            areas = _sibson_areas(sites, simplices, neighbours, centres, radii2, query[chunk])
            total = areas.sum(axis=1)
            r, c = np.nonzero(areas)
            rows.append(chunk[r])
            cols.append(c)
            vals.append(areas[r, c] / total[r])
    return csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(len(query), len(sites)),
    )


def sibson_interpolate(
    sites_xy: np.ndarray,
    values: np.ndarray,
    query_xy: np.ndarray,
    weights: csr_matrix | None = None,
) -> np.ndarray:
    """(M,): the natural-neighbour interpolant of the sites' values at the queries (nearest
    neighbour outside the hull); `weights` from `sibson_weights` saves recomputing them."""
    w = sibson_weights(sites_xy, query_xy) if weights is None else weights
    return np.asarray(w @ np.asarray(values, dtype=float)).reshape(-1)


def natural_neighbour_mask(
    sites_xy: np.ndarray,
    feasible: np.ndarray,
    query_xy: np.ndarray,
    weights: csr_matrix | None = None,
) -> np.ndarray:
    """(M,) bool: the 0/1 outcomes at the sites, Sibson-interpolated at the queries with
    nearest-neighbour extrapolation, above 0.5 (Sec. 9, item 4; a tie is infeasible)."""
    values = np.asarray(feasible, dtype=bool).astype(float)
    return sibson_interpolate(sites_xy, values, query_xy, weights) > THRESHOLD


# --- The campaign's outcomes ----------------------------------------------------------------


def paper_mc_starts(corridor: LosCorridor | None = None) -> np.ndarray:
    """(195, 3): Sec. 9's starts in T (z_T = 0), y_T outer, x_T inner."""
    corridor = LosCorridor() if corridor is None else corridor
    tan = math.tan(corridor.half_angle_rad)
    points = []
    for y in np.linspace(*MC_Y_RANGE_M, MC_Y_COUNT):
        for x in np.linspace(-MC_X_FILL * tan * y, MC_X_FILL * tan * y, MC_X_COUNT):
            points.append((x, y, 0.0))
    return np.array(points)


@dataclasses.dataclass(frozen=True, eq=False)
class McStart:
    """One closed-loop run of the campaign.

    Attributes:
        omega_deg: |w_IT_T| [deg/s].
        a_max_m_s2: The controller's a_max [m/s^2].
        p_T: (3,) the start in T (= p_LC_L at t = 0) [m].
        feasible: Choice 1.
        reason: One line: why the run is infeasible (or what it did, when feasible).
        run_id: The store's run id.
        status: The store's status ('ok' | 'failed').
        metrics: The run's summary (None for a run that failed before it had one).
    """

    omega_deg: float
    a_max_m_s2: float
    p_T: np.ndarray
    feasible: bool
    reason: str
    run_id: str
    status: str
    metrics: dict | None

    @property
    def contact(self) -> bool:
        m = self.metrics or {}
        return m.get("min_separation_m") is not None and m["min_separation_m"] <= 0.0


def _combination(overrides: dict) -> tuple[float, float] | None:
    spin = overrides.get("target.w_IT_T_deg_s")
    a_max = overrides.get("controller.a_max_m_s2")
    if spin is None or a_max is None or overrides.get("chaser.p_LC_L") is None:
        return None
    return round(float(np.linalg.norm(spin)), 6), round(float(a_max), 6)


def campaign_duration_s(rows: list[dict]) -> float | None:
    """The longest sim_time_s of the finished runs (None when none finished)."""
    times = [
        float(r["metrics"]["sim_time_s"])
        for r in rows
        if r.get("status") == "ok" and r.get("metrics") and "sim_time_s" in r["metrics"]
    ]
    return max(times) if times else None


def classify_run(row: dict, duration_s: float | None) -> tuple[bool, str]:
    """(feasible, reason) of one store row (module docstring, choice 1)."""
    metrics = row.get("metrics") or {}
    if row.get("status") != "ok":
        return False, f"early termination: {row.get('reason') or row.get('status')}"
    if not metrics:
        return False, "early termination: no summary"
    parts = []
    depth = float(metrics.get("los_violation_depth_m") or 0.0)
    violated = bool(metrics.get("los_violation", depth > VIOLATION_TOLERANCE_M))
    if violated:
        first = metrics.get("los_first_violation_s")
        when = f" from {first:.1f} s" if first is not None else ""
        length = metrics.get("los_violation_duration_s")
        span = f" for {length:.1f} s" if length is not None else ""
        parts.append(f"corridor violated {depth:.3f} m deep{when}{span}")
    sim_time = metrics.get("sim_time_s")
    stopped = metrics.get("stopped_early")
    short = duration_s is not None and sim_time is not None and sim_time < duration_s - 1e-6
    if stopped or short:
        parts.append(f"stopped at {sim_time:.1f} s" + (f" ({stopped})" if stopped else ""))
    if metrics.get("min_separation_m") is not None and metrics["min_separation_m"] <= 0.0:
        parts.append(f"contact ({metrics['min_separation_m']:.3f} m)")
    not_solved = metrics.get("los_qp_not_solved", metrics.get("los_qp_failures"))
    fallback = metrics.get("los_fallback_steps")
    extra = []
    if not_solved:
        extra.append(f"{not_solved} QPs not solved")
    if fallback:
        extra.append(f"{fallback} steps on a fallback")
    if not violated and not (stopped or short):
        held = "held" if metrics.get("los_held") else "not holding at the end"
        margin = metrics.get("los_min_face_distance_m")
        least = f", least margin {margin:.2f} m" if margin is not None else ""
        return True, "; ".join([f"no violation, {held}{least}", *parts, *extra])
    return False, "; ".join(parts + extra)


def mc_starts(
    rows: list[dict], duration_s: float | None = None
) -> dict[tuple[float, float], list[McStart]]:
    """{(omega_deg, a_max): the combination's runs, in plan order}: the rows that set the spin,
    a_max and the start (pending rows left out), classified (choice 1).

    Args:
        rows: `ResultStore.rows()` (dicts with status, overrides, metrics, run_id).
        duration_s: The campaign's duration; None: `campaign_duration_s(rows)`.
    """
    duration_s = campaign_duration_s(rows) if duration_s is None else duration_s
    out: dict[tuple[float, float], list[McStart]] = {}
    for row in rows:
        if row.get("status") == "pending":
            continue
        overrides = row.get("overrides") or {}
        key = _combination(overrides)
        if key is None:
            continue
        feasible, reason = classify_run(row, duration_s)
        p = np.zeros(3)
        start = np.asarray(overrides["chaser.p_LC_L"], dtype=float)
        p[: len(start)] = start
        out.setdefault(key, []).append(
            McStart(
                key[0],
                key[1],
                p,
                feasible,
                reason,
                str(row.get("run_id")),
                str(row.get("status")),
                row.get("metrics"),
            )
        )
    return out


def mc_outcomes(
    rows: list[dict], duration_s: float | None = None
) -> dict[tuple[float, float], tuple[np.ndarray, np.ndarray]]:
    """{(omega_deg, a_max): (sites_xy (K, 2), feasible (K,) bool)} from a campaign's rows."""
    return {
        key: (
            np.array([s.p_T[:2] for s in starts]).reshape(-1, 2),
            np.array([s.feasible for s in starts], dtype=bool),
        )
        for key, starts in mc_starts(rows, duration_s).items()
    }


# --- X_MC against the certified sets --------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False)
class McException:
    """An infeasible start blamed for grid points of X_nom outside X_MC (choice 4).

    Attributes:
        start: The run.
        grid_points: How many such grid points have it as their nearest infeasible start.
        start_in_nominal: The start itself satisfies criterion (16) with eq. 14: a certified
            start that failed in closed loop; False: the interpolation carried an uncertified
            failure into X_nom.
    """

    start: McStart
    grid_points: int
    start_in_nominal: bool


@dataclasses.dataclass(frozen=True, eq=False)
class McCombination:
    """One (omega_t, a_max) of the campaign beside the analytical sets.

    Attributes:
        omega_deg: [deg/s].
        a_max_m_s2: [m/s^2].
        r_sync_m: Eq. 14.
        starts: The combination's runs.
        mc_percent: X_MC's share of the cone (%).
        nominal_percent: X_nom's (%), ours.
        stochastic_percent: X_stoch's (%), NoiseModel() defaults.
        robust_percent: X_rob's (%).
        paper_nominal_percent: Table 2 (None off the table).
        nominal_not_mc: Grid points in X_nom but not in X_MC.
        nominal_not_mc_extrapolated: Those of them outside the starts' convex hull, where X_MC
            is the nearest start's outcome (y_T < 20 m, y_T > 300 m, the faces' 5 % wedges).
        stochastic_not_mc: ... in X_stoch but not in X_MC.
        robust_not_mc: ... in X_rob but not in X_MC.
        exceptions: The infeasible starts behind nominal_not_mc, most grid points first.
        start_certified: (K,) bool: each start satisfies (16) with (14) at its own position.
        nominal_starts_infeasible: The certified starts that are infeasible.
        masks: {"mc", "nominal", "stochastic", "robust"}: (n * n,) bool on the grid.
        grid: The grid.
    """

    omega_deg: float
    a_max_m_s2: float
    r_sync_m: float
    starts: tuple[McStart, ...]
    mc_percent: float
    nominal_percent: float
    stochastic_percent: float
    robust_percent: float
    paper_nominal_percent: float | None
    nominal_not_mc: int
    nominal_not_mc_extrapolated: int
    stochastic_not_mc: int
    robust_not_mc: int
    exceptions: tuple[McException, ...]
    start_certified: np.ndarray
    nominal_starts_infeasible: tuple[McStart, ...]
    masks: dict = dataclasses.field(repr=False)
    grid: reach.SafeStartGrid = dataclasses.field(repr=False)

    @property
    def feasible_starts(self) -> int:
        return sum(s.feasible for s in self.starts)

    @property
    def feasible_share_percent(self) -> float:
        return 100.0 * self.feasible_starts / len(self.starts) if self.starts else math.nan

    @property
    def nominal_starts(self) -> int:
        return int(np.count_nonzero(self.start_certified))

    @property
    def failed_runs(self) -> int:
        return sum(s.status != "ok" for s in self.starts)

    @property
    def sites_xy(self) -> np.ndarray:
        return np.array([s.p_T[:2] for s in self.starts]).reshape(-1, 2)

    @property
    def feasible(self) -> np.ndarray:
        return np.array([s.feasible for s in self.starts], dtype=bool)


def _hull_mask(sites: np.ndarray, query: np.ndarray) -> np.ndarray:
    """(M,) bool: the queries inside the sites' convex hull (none for degenerate sites)."""
    try:
        return _strictly_inside_hull(sites, query, 0.0)
    except (QhullError, ValueError):
        return np.zeros(len(query), dtype=bool)


def mc_report(
    rows: list[dict],
    y_max_m: float = reach.GRID_Y_MAX_M,
    resolution: int = reach.GRID_RESOLUTION,
    corridor: LosCorridor | None = None,
    noise: reach.NoiseModel | None = None,
    duration_s: float | None = None,
) -> list[McCombination]:
    """One record per (omega_t, a_max) in the rows, in Table 2's order (others after): X_MC on
    the grid (choices 2-3), the certified sets, and the check X_nom within X_MC (choice 4).

    Args:
        rows: `ResultStore.rows()`.
        y_max_m: The grid's far edge (reachability's choice 1).
        resolution: The grid's n (n x n).
        corridor: The corridor (default: Table 1's, LosCorridor()).
        noise: X_stoch's and X_rob's disturbances (default: NoiseModel()).
        duration_s: The campaign's duration (None: the longest finished run).
    """
    corridor = LosCorridor() if corridor is None else corridor
    grid = reach.SafeStartGrid.over_cone(corridor, y_max_m, resolution)
    terms = reach.GridSlack.on(grid, corridor)
    query = grid.points_T[:, :2]
    by_combination = mc_starts(rows, duration_s)
    order = {key: i for i, key in enumerate(reach.COMBINATIONS)}
    keys = sorted(by_combination, key=lambda k: (order.get(k, len(order)), k))
    weights_cache: list[tuple[np.ndarray, csr_matrix]] = []
    records = []
    for key in keys:
        starts = tuple(by_combination[key])
        sites = np.array([s.p_T[:2] for s in starts])
        feasible = np.array([s.feasible for s in starts], dtype=bool)
        weights = next((w for s, w in weights_cache if np.array_equal(s, sites)), None)
        if weights is None:  # the same 195 starts in every combination: once for all 20
            weights = sibson_weights(sites, query)
            weights_cache.append((sites, weights))
        omega = math.radians(key[0])
        sets = reach.certified_sets(terms, omega, key[1], noise)
        mc = natural_neighbour_mask(sites, feasible, query, weights) & grid.inside
        masks = {"mc": mc, **sets}
        exceptions_mask = sets["nominal"] & ~mc
        at_starts = reach.certified_mask(
            reach.GridSlack.on(
                reach.SafeStartGrid.at_points(np.array([s.p_T for s in starts]), corridor), corridor
            ),
            omega,
            key[1],
        )
        exceptions = []
        if exceptions_mask.any() and not feasible.all():
            bad = np.flatnonzero(~feasible)
            _, nearest = cKDTree(sites[bad]).query(query[exceptions_mask])
            blamed, counts = np.unique(bad[nearest], return_counts=True)
            for i in np.argsort(-counts, kind="stable"):
                exceptions.append(
                    McException(starts[blamed[i]], int(counts[i]), bool(at_starts[blamed[i]]))
                )
        records.append(
            McCombination(
                omega_deg=key[0],
                a_max_m_s2=key[1],
                r_sync_m=sync_range_m(key[1], omega),
                starts=starts,
                mc_percent=reach.safe_fraction(mc, grid),
                nominal_percent=reach.safe_fraction(sets["nominal"], grid),
                stochastic_percent=reach.safe_fraction(sets["stochastic"], grid),
                robust_percent=reach.safe_fraction(sets["robust"], grid),
                paper_nominal_percent=reach.PAPER_TABLE_2.get(key),
                nominal_not_mc=int(np.count_nonzero(exceptions_mask)),
                nominal_not_mc_extrapolated=int(
                    np.count_nonzero(exceptions_mask & ~_hull_mask(sites, query))
                ),
                stochastic_not_mc=int(np.count_nonzero(sets["stochastic"] & ~mc)),
                robust_not_mc=int(np.count_nonzero(sets["robust"] & ~mc)),
                exceptions=tuple(exceptions),
                start_certified=at_starts,
                nominal_starts_infeasible=tuple(
                    s for s, certified in zip(starts, at_starts) if certified and not s.feasible
                ),
                masks=masks,
                grid=grid,
            )
        )
    return records


HOLDING_BANDS = ("r <= r_hold", "r_hold < r <= r_sync", "r > r_sync")  # holding_bands' keys


def holding_bands(records: list[McCombination]) -> dict[str, tuple[int, int]]:
    """{band: (feasible starts, starts)} over every combination, each start placed by its range
    |p_T| against its combination's holding range r_hold (rpod.models.los_corridor.
    holding_range_m) and r_sync. Paper 004's conclusion 5 says a start inside r_sync can be
    held; the bands say where that holds."""
    counts = {name: [0, 0] for name in HOLDING_BANDS}
    for record in records:
        r_hold = holding_range_m(record.a_max_m_s2, math.radians(record.omega_deg))
        for start in record.starts:
            r = float(np.linalg.norm(start.p_T))
            band = HOLDING_BANDS[0 if r <= r_hold else 1 if r <= record.r_sync_m else 2]
            counts[band][0] += int(start.feasible)
            counts[band][1] += 1
    return {name: (feasible, total) for name, (feasible, total) in counts.items()}
