"""Tests for rpod.planners.reachability_mc: Sibson's natural-neighbour interpolation, the
classification of a campaign's runs, and X_MC against the certified sets (paper 004 Secs. 9-10).

Truths: Sibson weights worked out by hand (a square of sites, the Voronoi areas by hand); the
weights' linear precision (sum_i w_i p_i = q, an identity of Sibson's coordinates, to 1e-9 m on
sites ~1 m apart: round-off of areas built from products of 1 m coordinates); the weights
against an independent raster estimate of the stolen areas (nearest-site labelling of a fine
raster, which converges as the cell size: 2e-3 at 1200 x 1200 cells); and campaigns whose
outcome is known by construction (feasible iff the start is near X_nom; a planted failure).
"""

import math
import types

import numpy as np
import pytest
from scipy.sparse import csr_matrix
from scipy.spatial import ConvexHull, cKDTree

from rpod.models.los_corridor import LosCorridor
from rpod.planners import reachability as reach
from rpod.planners import reachability_mc as mc

CORRIDOR = LosCorridor()
SQUARE = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 2.0], [2.0, 2.0]])


# --- Sibson weights ---------------------------------------------------------------------------


def test_square_by_hand():
    # q = (0.5, 0.5) in the square of side 2. q's new cell is bounded by the bisectors x + y =
    # 0.5 (with (0, 0)), 3x - y = 3.5 ((2, 0)), 3y - x = 3.5 ((0, 2)), x + y = 2.5 ((2, 2)):
    # the quadrilateral (1, -0.5), (1.5, 1), (1, 1.5), (-0.5, 1) of area 2. The old cells are
    # the quadrants about (1, 1), so the stolen areas are the triangles 1.125, 0.375, 0.375 and
    # 0.125: weights 9/16, 3/16, 3/16, 1/16.
    w = mc.sibson_weights(SQUARE, np.array([[0.5, 0.5]])).toarray()[0]
    np.testing.assert_allclose(w, [9 / 16, 3 / 16, 3 / 16, 1 / 16], rtol=0, atol=1e-14)
    # The centre: all four sites are on one circle (the triangulation's diagonal is arbitrary,
    # Sibson's weights are not): a quarter each; the same by symmetry at (1.5, 0.5) mirrored.
    w = mc.sibson_weights(SQUARE, np.array([[1.0, 1.0], [1.5, 0.5]])).toarray()
    np.testing.assert_allclose(w[0], [0.25] * 4, rtol=0, atol=1e-14)
    np.testing.assert_allclose(w[1], [3 / 16, 9 / 16, 1 / 16, 3 / 16], rtol=0, atol=1e-14)


def test_values_at_sites_outside_and_on_the_hull_are_the_nearest_sites():
    rng = np.random.default_rng(1)
    sites = rng.uniform(0.0, 10.0, (30, 2))
    values = rng.uniform(-1.0, 1.0, 30)
    np.testing.assert_allclose(mc.sibson_interpolate(sites, values, sites), values, atol=1e-15)
    outside = np.array([[-5.0, -5.0], [15.0, 3.0], [5.0, 40.0]])
    nearest = cKDTree(sites).query(outside)[1]
    np.testing.assert_array_equal(mc.sibson_interpolate(sites, values, outside), values[nearest])
    # A point of a hull edge (a tenth of the way along it) is not strictly inside: nearest.
    hull = ConvexHull(sites).vertices
    on_edge = 0.9 * sites[hull[0]] + 0.1 * sites[hull[1]]
    got = mc.sibson_interpolate(sites, values, on_edge[None])[0]
    assert got == values[hull[0]]


def test_linear_precision_on_random_sites():
    # Sibson's coordinates reproduce linear functions exactly (before any threshold).
    rng = np.random.default_rng(7)
    sites = rng.uniform(0.0, 1.0, (150, 2))
    query = rng.uniform(0.0, 1.0, (20000, 2))
    inside = mc._strictly_inside_hull(sites, query, 1e-9)
    assert inside.sum() > 17000  # ~90 %: the hull of 150 random sites
    weights = mc.sibson_weights(sites, query)
    assert np.all(weights.data > -1e-12)
    np.testing.assert_allclose(np.asarray(weights.sum(axis=1)).ravel(), 1.0, atol=1e-12)
    f = 3.0 - 2.0 * sites[:, 0] + 5.0 * sites[:, 1]
    expected = 3.0 - 2.0 * query[:, 0] + 5.0 * query[:, 1]
    got = mc.sibson_interpolate(sites, f, query, weights)
    np.testing.assert_allclose(got[inside], expected[inside], rtol=0, atol=1e-9)
    assert np.max(np.abs(weights @ sites - query)[inside]) < 1e-9
    # Nearest-neighbour weights are not linearly precise: the test can fail.
    nearest = csr_matrix(
        (np.ones(len(query)), (np.arange(len(query)), cKDTree(sites).query(query)[1])),
        shape=weights.shape,
    )
    assert np.max(np.abs(nearest @ sites - query)[inside]) > 1e-3


def test_weights_match_a_raster_of_the_stolen_areas():
    # Independent: label a fine raster by nearest site with and without q; the cells that q
    # takes, counted by their old site, are the stolen areas.
    sites = np.array([[0.0, 0.0], [4.0, 0.3], [1.2, 3.5], [4.4, 4.1], [2.1, 1.4], [0.3, 2.2]])
    queries = np.array([[2.0, 2.0], [1.0, 1.0], [3.1, 2.6]])
    weights = mc.sibson_weights(sites, queries).toarray()
    n = 1200
    x = np.linspace(-1.0, 5.5, n)
    y = np.linspace(-1.0, 5.5, n)
    X, Y = np.meshgrid(x, y)
    cells = np.column_stack([X.ravel(), Y.ravel()])
    d_old, owner = cKDTree(sites).query(cells)
    for q, w in zip(queries, weights):
        taken = np.linalg.norm(cells - q, axis=1) < d_old
        assert not taken[np.abs(cells).max(axis=1) > 5.4].any()  # the raster holds q's cell
        raster = np.bincount(owner[taken], minlength=len(sites)) / taken.sum()
        np.testing.assert_allclose(w, raster, rtol=0, atol=2e-3)


def test_threshold_and_tie():
    # Two feasible sites on one side of the square: 0.5 at the centre, a tie, infeasible.
    feasible = np.array([True, True, False, False])
    centre = np.array([[1.0, 1.0]])
    assert mc.sibson_interpolate(SQUARE, feasible, centre)[0] == pytest.approx(0.5, abs=1e-14)
    tie = csr_matrix(np.array([[0.5, 0.0, 0.5, 0.0]]))
    assert not mc.natural_neighbour_mask(SQUARE, feasible, centre, weights=tie)[0]
    # 9/16 + 3/16 feasible at (0.5, 0.5); 3/16 + 1/16 at (1.5, 1.5).
    mask = mc.natural_neighbour_mask(SQUARE, feasible, np.array([[0.5, 0.5], [1.5, 1.5]]))
    np.testing.assert_array_equal(mask, [True, False])


def test_degenerate_sites():
    with pytest.raises(ValueError, match="distinct"):
        mc.sibson_weights(np.array([[0.0, 0.0], [0.0, 0.0], [1.0, 1.0]]), np.zeros((1, 2)))
    line = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])  # collinear: nearest neighbour
    got = mc.sibson_interpolate(line, [0.0, 1.0, 2.0], np.array([[1.8, 0.5]]))
    assert got[0] == 2.0


# --- Synthetic campaigns ----------------------------------------------------------------------


def _row(run_id, omega, a_max, p, feasible=True, status="ok", sim_time_s=400.0, stopped=None):
    overrides = {
        "target.w_IT_T_deg_s": [0.0, 0.0, omega],
        "controller.a_max_m_s2": a_max,
        "chaser.p_LC_L": [float(p[0]), float(p[1]), 0.0],
    }
    if status == "pending":
        return {"run_id": run_id, "status": "pending", "overrides": overrides, "metrics": None}
    if status == "failed":
        return {
            "run_id": run_id,
            "status": "failed",
            "reason": "error: RuntimeError: boom",
            "overrides": overrides,
            "metrics": None,
        }
    metrics = {
        "status": "ok",
        "sim_time_s": sim_time_s,
        "min_separation_m": 5.0,
        "los_violation": not feasible,
        "los_violation_depth_m": 0.0 if feasible else 0.42,
        "los_violation_duration_s": 0.0 if feasible else 7.0,
        "los_first_violation_s": None if feasible else 31.0,
        "los_min_face_distance_m": 2.0 if feasible else -0.42,
        "los_held": feasible,
        "los_qp_not_solved": 0,
        "los_fallback_steps": 0 if feasible else 3,
        "stopped_early": stopped,
    }
    return {"run_id": run_id, "status": "ok", "overrides": overrides, "metrics": metrics}


def _campaign(omega, a_max, feasible_at, prefix="r"):
    starts = mc.paper_mc_starts(CORRIDOR)
    return [
        _row(f"{prefix}{i}", omega, a_max, p, feasible=bool(feasible_at(p)))
        for i, p in enumerate(starts)
    ]


@pytest.fixture(scope="module")
def grid_terms():
    grid = reach.SafeStartGrid.over_cone(CORRIDOR)
    return grid, reach.GridSlack.on(grid, CORRIDOR)


def _near_nominal(grid, terms, omega, a_max, distance_m):
    """feasible_at(p): p within distance_m of X_nom's grid points."""
    nominal = reach.certified_mask(terms, math.radians(omega), a_max)
    tree = cKDTree(grid.points_T[nominal, :2])
    return lambda p: tree.query(p[:2])[0] < distance_m


def test_classification_and_outcomes():
    rows = [
        _row("a", 2.0, 0.1, (0.0, 100.0)),
        _row("b", 2.0, 0.1, (10.0, 100.0), feasible=False),
        _row("c", 2.0, 0.1, (20.0, 100.0), status="failed"),
        _row("d", 2.0, 0.1, (30.0, 100.0), status="pending"),
        _row("e", 2.0, 0.1, (0.0, 40.0), sim_time_s=120.0, stopped="corridor violated"),
        _row("f", 2.0, 0.1, (0.0, 60.0), sim_time_s=250.0),  # ended early, no violation
        _row("g", 3.0, 0.2, (0.0, 80.0)),
        {"run_id": "x", "status": "ok", "overrides": {"duration_s": 5.0}, "metrics": {}},
    ]
    outcomes = mc.mc_outcomes(rows)
    assert set(outcomes) == {(2.0, 0.1), (3.0, 0.2)}
    sites, feasible = outcomes[(2.0, 0.1)]
    np.testing.assert_array_equal(sites, [[0, 100], [10, 100], [20, 100], [0, 40], [0, 60]])
    np.testing.assert_array_equal(feasible, [True, False, False, False, False])
    starts = mc.mc_starts(rows)[(2.0, 0.1)]
    assert "0.420 m deep from 31.0 s for 7.0 s" in starts[1].reason
    assert starts[2].reason.startswith("early termination: error: RuntimeError")
    assert "stopped at 120.0 s (corridor violated)" in starts[3].reason
    assert "stopped at 250.0 s" in starts[4].reason
    assert starts[0].reason.startswith("no violation, held")
    # With the duration given as 250 s, run f flew all of it.
    assert mc.mc_outcomes(rows, duration_s=250.0)[(2.0, 0.1)][1][4]


def test_store_rows_round_trip(tmp_path):
    # The same rows through the real results store (JSON columns) classify the same.
    from rpod.scenarios.store import ResultStore

    rows = [
        _row(f"r{i}", 1.0, 0.2, (5.0 * i, 50.0 + 10 * i), feasible=i % 2 == 0) for i in range(4)
    ]
    runs = [
        types.SimpleNamespace(
            run_id=r["run_id"],
            index=i,
            group="g",
            case=r["run_id"],
            grid_point={},
            sample_index=None,
            overrides=r["overrides"],
        )
        for i, r in enumerate(rows)
    ]
    with ResultStore(tmp_path / "results.sqlite") as store:
        store.write_plan({"campaign_name": "t"}, runs)
        for r in rows[:3]:
            store.record(r["run_id"], {"status": "ok", "metrics": r["metrics"], "wall_time_s": 1.0})
    with ResultStore.open_existing(tmp_path) as store:
        stored = store.rows()
    sites, feasible = mc.mc_outcomes(stored)[(1.0, 0.2)]
    np.testing.assert_array_equal(feasible, [True, False, True])  # r3 still pending
    np.testing.assert_array_equal(sites, [[0.0, 50.0], [5.0, 60.0], [10.0, 70.0]])


def test_report_nominal_within_mc(grid_terms):
    # Feasible iff within 30 m (more than one start spacing) of X_nom: X_nom within X_MC at
    # every grid point, and X_MC beyond X_nom.
    grid, terms = grid_terms
    rows = _campaign(2.0, 0.10, _near_nominal(grid, terms, 2.0, 0.10, 30.0))
    [record] = mc.mc_report(rows)
    assert (record.omega_deg, record.a_max_m_s2) == (2.0, 0.1)
    assert len(record.starts) == 195
    assert 0 < record.feasible_starts < 195
    assert record.nominal_not_mc == 0 and record.exceptions == ()
    assert record.stochastic_not_mc == record.robust_not_mc == 0
    assert record.nominal_starts_infeasible == ()
    assert record.nominal_starts > 0
    assert record.nominal_percent == pytest.approx(11.3, abs=0.2)  # Table 2
    assert record.paper_nominal_percent == 11.3
    assert record.mc_percent > record.nominal_percent
    assert record.robust_percent <= record.stochastic_percent <= record.nominal_percent
    mc_mask = record.masks["mc"]
    assert not (mc_mask & ~grid.inside).any()
    assert reach.safe_fraction(mc_mask, grid) == record.mc_percent


def test_report_names_a_planted_failure(grid_terms):
    grid, terms = grid_terms
    near = _near_nominal(grid, terms, 2.0, 0.10, 30.0)
    starts = mc.paper_mc_starts(CORRIDOR)
    at_starts = reach.certified_mask(
        reach.GridSlack.on(reach.SafeStartGrid.at_points(starts, CORRIDOR), CORRIDOR),
        math.radians(2.0),
        0.1,
    )
    planted = int(np.flatnonzero(at_starts)[len(np.flatnonzero(at_starts)) // 2])
    rows = _campaign(2.0, 0.10, near)
    rows[planted] = _row(rows[planted]["run_id"], 2.0, 0.1, starts[planted], feasible=False)
    [record] = mc.mc_report(rows)
    assert record.nominal_not_mc > 0
    assert [s.run_id for s in record.nominal_starts_infeasible] == [f"r{planted}"]
    first = record.exceptions[0]
    assert first.start.run_id == f"r{planted}" and first.start_in_nominal
    assert first.grid_points == record.nominal_not_mc  # every exception is next to it
    assert record.nominal_not_mc_extrapolated == 0
    np.testing.assert_allclose(first.start.p_T, starts[planted])
    assert "corridor violated 0.420 m deep" in first.start.reason


def test_certified_outcome_smears_across_the_edge(grid_terms):
    # Feasible iff certified at the start: the 195 starts cannot draw X_nom's edge, so X_nom's
    # rim interpolates below 0.5 (a property of the interpolation, not of any run); every
    # exception is blamed on an uncertified start, and no certified start failed.
    starts = mc.paper_mc_starts(CORRIDOR)
    at_starts = reach.certified_mask(
        reach.GridSlack.on(reach.SafeStartGrid.at_points(starts, CORRIDOR), CORRIDOR),
        math.radians(2.0),
        0.1,
    )
    rows = [
        _row(f"r{i}", 2.0, 0.1, p, feasible=bool(c))
        for i, (p, c) in enumerate(zip(starts, at_starts))
    ]
    [record] = mc.mc_report(rows)
    assert record.feasible_starts == record.nominal_starts == int(at_starts.sum())
    assert record.nominal_starts_infeasible == ()
    assert record.nominal_not_mc > 0
    assert all(not e.start_in_nominal for e in record.exceptions)
    assert sum(e.grid_points for e in record.exceptions) == record.nominal_not_mc


def test_report_order_and_a_reduced_grid():
    rows = _campaign(3.0, 0.2, lambda p: p[1] < 150.0, "b") + _campaign(
        1.0, 0.05, lambda p: True, "a"
    )
    records = mc.mc_report(rows, resolution=60)
    assert [(r.omega_deg, r.a_max_m_s2) for r in records] == [(1.0, 0.05), (3.0, 0.2)]
    assert records[0].mc_percent == 100.0 and records[0].nominal_not_mc == 0
    assert records[1].feasible_starts == 7 * 13  # y = 20 .. 140 m
    assert len(records[1].masks["mc"]) == 3600


def test_figures_are_written(tmp_path, grid_terms):
    # Fig. 2 and Fig. 3 (los_corridor.monte_carlo_figures) from a two-combination campaign:
    # both PNGs readable and not blank; no overlay without 2 deg/s, 0.10 m/s^2.
    import matplotlib.image

    from rpod.diagrams.controllers.los_corridor.monte_carlo_figures import write_mc_figures

    grid, terms = grid_terms
    rows = _campaign(2.0, 0.10, _near_nominal(grid, terms, 2.0, 0.10, 30.0), "a") + _campaign(
        3.0, 0.05, lambda p: p[1] < 60.0, "b"
    )
    paths = write_mc_figures(rows, tmp_path, prefix="mc")
    assert [p.name for p in paths] == ["mc_maps.png", "mc_overlay.png"]
    for path in paths:
        image = matplotlib.image.imread(path)
        assert len(np.unique(image.reshape(-1, image.shape[-1]), axis=0)) > 5
    assert write_mc_figures(rows[195:], tmp_path / "b") == [tmp_path / "b/los_monte_carlo_maps.png"]


def test_small_r_sync_is_all_extrapolated():
    # 5 deg/s, 0.02 m/s^2: r_sync = 5.3 m, X_nom lies below the nearest starts (y_T = 20 m),
    # so X_MC there is those starts' outcome: all infeasible, every point of X_nom is lost,
    # and the report says it is extrapolation.
    [record] = mc.mc_report(_campaign(5.0, 0.02, lambda p: False))
    assert record.nominal_starts == 0 and record.mc_percent == 0.0
    assert record.nominal_not_mc > 0
    assert record.nominal_not_mc_extrapolated == record.nominal_not_mc
    assert all(e.start.p_T[1] == 20.0 for e in record.exceptions)


def test_holding_bands_place_each_start_by_its_range_against_r_sync():
    """r_sync = 100 m (a_max 0.1 m/s^2): starts at 30 and 49.9 m are within r_hold = 50 m, 70 and
    99.9 m between r_hold and r_sync, 150 m beyond; the feasible ones are counted per band."""

    def start(y, feasible):
        return mc.McStart(2.0, 0.1, np.array([0.0, y, 0.0]), feasible, "", "id", "ok", {})

    omega = math.sqrt(2 * 0.1 / 100.0)  # r_sync = 2 a_max / omega^2 = 100 m
    record = types.SimpleNamespace(
        omega_deg=math.degrees(omega),
        a_max_m_s2=0.1,
        r_sync_m=100.0,
        starts=[start(30, True), start(49.9, False), start(70, True), start(99.9, False)]
        + [start(150, False)],
    )
    bands = mc.holding_bands([record])
    assert bands == {
        "r <= r_hold": (1, 2),
        "r_hold < r <= r_sync": (1, 2),
        "r > r_sync": (0, 1),
    }
