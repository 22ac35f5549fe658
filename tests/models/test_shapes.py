"""Tests for rpod.models.shapes against closed forms and an independent feature enumeration."""

import itertools

import numpy as np
import pytest
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RotationMatrix
from scipy.optimize import lsq_linear
from scipy.spatial import ConvexHull

from rpod.models.shapes import (
    ContactTest,
    ConvexPolytope,
    edge_directions,
    halfspaces_are_bounded,
    separation_distance,
    soft_capture_chaser_hull,
    soft_capture_target_hull,
)

IDENTITY = RotationMatrix()
ORIGIN = np.zeros(3)
# Clarabel runs at 1e-12 tolerances; observed errors are ~1e-13 m on metre-sized boxes, so
# 1e-8 m is a safe bound that still catches any geometric mistake.
TOL = 1e-8


def _random_rotation(rng) -> RotationMatrix:
    q = rng.normal(size=4)
    return RotationMatrix(Quaternion(q / np.linalg.norm(q)))


# ---- Independent reference for two boxes -------------------------------------------------------
# For disjoint convex polytopes the closest points can always be taken as a vertex of one and a
# point of the other, or a point on an edge of each. Vertex-to-solid-box distance is the clamp
# formula; edge-to-edge distance is a 2-variable bounded least squares (scipy BVLS).


def _posed_box(size, R, p):
    half = 0.5 * np.asarray(size, dtype=float)
    R = R.matrix()
    corners = {s: p + R @ (np.array(s) * half) for s in itertools.product((-1, 1), repeat=3)}
    edges = [
        (corners[s], corners[t])
        for s, t in itertools.combinations(corners, 2)
        if sum(a != b for a, b in zip(s, t)) == 1
    ]
    assert len(edges) == 12
    return half, R, np.asarray(p, dtype=float), list(corners.values()), edges


def _point_to_box(point, half, R, p):
    local = R.T @ (point - p)
    return np.linalg.norm(np.maximum(np.abs(local) - half, 0.0))


def _segment_to_segment(a0, a1, b0, b1):
    M = np.column_stack([a1 - a0, -(b1 - b0)])
    sol = lsq_linear(M, b0 - a0, bounds=(0.0, 1.0), method="bvls")
    return np.linalg.norm(M @ sol.x - (b0 - a0))


def _brute_force_box_distance(size_a, R_a, p_a, size_b, R_b, p_b):
    ha, Ra, pa, Va, Ea = _posed_box(size_a, R_a, p_a)
    hb, Rb, pb, Vb, Eb = _posed_box(size_b, R_b, p_b)
    candidates = [_point_to_box(v, hb, Rb, pb) for v in Va]
    candidates += [_point_to_box(v, ha, Ra, pa) for v in Vb]
    candidates += [_segment_to_segment(*ea, *eb) for ea in Ea for eb in Eb]
    return min(candidates)


def _boxes_overlap_sat(size_a, R_a, p_a, size_b, R_b, p_b):
    """Separating-axis test for two boxes (15 axes): True when they intersect."""
    ha, hb = 0.5 * np.asarray(size_a), 0.5 * np.asarray(size_b)
    A, B = R_a.matrix(), R_b.matrix()
    axes = [A[:, i] for i in range(3)] + [B[:, j] for j in range(3)]
    axes += [np.cross(A[:, i], B[:, j]) for i in range(3) for j in range(3)]
    d = np.asarray(p_b) - np.asarray(p_a)
    for axis in axes:
        if np.linalg.norm(axis) < 1e-12:
            continue
        ra = np.sum(ha * np.abs(A.T @ axis))
        rb = np.sum(hb * np.abs(B.T @ axis))
        if abs(d @ axis) > ra + rb:
            return False
    return True


# ---- Closed-form cases -------------------------------------------------------------------------


@pytest.mark.parametrize("gap", [0.0, 1e-3, 0.37, 5.0])
@pytest.mark.parametrize("roll", [0.0, 0.3, 1.1])
def test_face_to_face_gap(gap, roll):
    # a: 1 x 2 x 3 box at the origin; b: 0.5 cube whose -x face is `gap` beyond a's +x face.
    # Rolling b about x keeps its x faces parallel, so the distance stays exactly `gap`.
    a = ConvexPolytope.box([1.0, 2.0, 3.0])
    b = ConvexPolytope.box([0.5, 0.5, 0.5])
    R_b = RotationMatrix.MakeXRotation(roll)
    p_b = np.array([0.5 + 0.25 + gap, 0.2, -0.4])
    assert separation_distance(a, IDENTITY, ORIGIN, b, R_b, p_b) == pytest.approx(gap, abs=TOL)
    # Same scene seen from a rotated, translated world frame: distance is invariant.
    R = RotationMatrix(AngleAxis(0.8, np.array([1.0, 2.0, -1.0]) / np.sqrt(6.0)))
    p = np.array([10.0, -3.0, 7.0])
    moved = separation_distance(a, R, p, b, R.multiply(R_b), p + R.multiply(p_b))
    assert moved == pytest.approx(gap, abs=TOL)


@pytest.mark.parametrize("s", [1.0, 1.05, 2.0, 7.5])
def test_corner_to_corner_along_diagonal(s):
    # Unit cubes, b's centre at (s, s, s): the nearest points are a's corner (0.5, 0.5, 0.5) and
    # b's corner (s - 0.5, ...), so the distance is sqrt(3) (s - 1).
    cube = ConvexPolytope.box([1.0, 1.0, 1.0])
    d = separation_distance(cube, IDENTITY, ORIGIN, cube, IDENTITY, np.full(3, s))
    assert d == pytest.approx(np.sqrt(3.0) * (s - 1.0), abs=TOL)


def test_corner_pointing_at_face():
    # b (cube of edge 0.4) is turned so its body diagonal (1, 1, 1) points along -x, towards a's
    # +x face at x = 0.5. Its nearest corner is sqrt(3) * 0.2 from its centre at x = 2.
    u = np.ones(3) / np.sqrt(3.0)
    v = np.array([-1.0, 0.0, 0.0])
    axis = np.cross(u, v)
    R_b = RotationMatrix(AngleAxis(np.arccos(u @ v), axis / np.linalg.norm(axis)))
    a = ConvexPolytope.box([1.0, 1.0, 1.0])
    b = ConvexPolytope.box([0.4, 0.4, 0.4])
    d = separation_distance(a, IDENTITY, ORIGIN, b, R_b, np.array([2.0, 0.1, -0.2]))
    assert d == pytest.approx(2.0 - 0.5 - np.sqrt(3.0) * 0.2, abs=TOL)


# ---- Random poses against the independent references -------------------------------------------


def test_random_rotated_boxes_match_brute_force_and_sat():
    rng = np.random.default_rng(7)
    size_a = np.array([1.0, 2.0, 3.0])  # target-like bus
    size_b = np.array([0.6, 0.4, 1.5])  # chaser-like
    a, b = ConvexPolytope.box(size_a), ConvexPolytope.box(size_b)
    n_separated = n_overlapping = 0
    for _ in range(40):
        R_a, R_b = _random_rotation(rng), _random_rotation(rng)
        p_a = rng.uniform(-1.0, 1.0, 3)
        direction = rng.normal(size=3)
        p_b = p_a + rng.uniform(0.5, 3.5) * direction / np.linalg.norm(direction)
        d = separation_distance(a, R_a, p_a, b, R_b, p_b)
        if _boxes_overlap_sat(size_a, R_a, p_a, size_b, R_b, p_b):
            n_overlapping += 1
            assert d == 0.0
        else:
            n_separated += 1
            # Both sides are exact up to round-off (BVLS) and solver tolerance (Clarabel).
            reference = _brute_force_box_distance(size_a, R_a, p_a, size_b, R_b, p_b)
            assert d == pytest.approx(reference, abs=TOL)
    # The sample must exercise both branches.
    assert n_separated >= 10 and n_overlapping >= 5


def test_overlap_and_containment_return_zero():
    a = ConvexPolytope.box([1.0, 2.0, 3.0])
    b = ConvexPolytope.box([0.2, 0.2, 0.2])
    # b entirely inside a, b crossing a's face, and two identical boxes: all exactly 0.
    assert separation_distance(a, IDENTITY, ORIGIN, b, IDENTITY, np.array([0.1, 0.2, 0.3])) == 0.0
    assert separation_distance(a, IDENTITY, ORIGIN, b, IDENTITY, np.array([0.55, 0.0, 0.0])) == 0.0
    assert separation_distance(a, IDENTITY, ORIGIN, a, IDENTITY, ORIGIN) == 0.0


def test_from_vertices_hull_matches_box():
    rng = np.random.default_rng(11)
    box = ConvexPolytope.box([0.8, 1.2, 0.5])
    # The hull of the corners plus interior points keeps exactly the 8 corners.
    points = np.vstack([box.vertices, rng.uniform(-0.2, 0.2, size=(10, 3))])
    hull = ConvexPolytope.from_vertices(points)
    assert len(hull.vertices) == 8
    # Every box corner satisfies the hull's halfspaces (tight), and a point outside does not.
    assert np.all(box.vertices @ hull.A.T <= hull.b + 1e-12)
    assert np.any(np.array([0.41, 0.0, 0.0]) @ hull.A.T > hull.b)
    # Same geometry, same distance (both computed by the same QP; checks the vertex set).
    other = ConvexPolytope.box([1.0, 1.0, 1.0])
    R = RotationMatrix.MakeZRotation(0.4)
    p = np.array([1.7, 0.3, 0.1])
    assert separation_distance(hull, IDENTITY, ORIGIN, other, R, p) == pytest.approx(
        separation_distance(box, IDENTITY, ORIGIN, other, R, p), abs=TOL
    )


def test_rejects_bad_shapes():
    with pytest.raises(ValueError, match="positive"):
        ConvexPolytope.box([1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="outside"):
        ConvexPolytope(A=np.eye(3), b=np.zeros(3), vertices=np.ones((1, 3)))
    with pytest.raises(ValueError, match=r"\(m, 3\)"):
        ConvexPolytope(A=np.eye(2), b=np.zeros(2), vertices=np.zeros((1, 3)))


# ---- Halfspace constructor and the paper 000 hulls ---------------------------------------------


def _same_point_sets(p, q, atol=1e-12):
    """True when the rows of p and q are the same points, in any order."""
    p, q = np.asarray(p), np.asarray(q)
    if p.shape != q.shape:
        return False
    distances = np.linalg.norm(p[:, None, :] - q[None, :, :], axis=2)
    return bool(np.all(distances.min(axis=1) < atol) and np.all(distances.min(axis=0) < atol))


def _polygon_area(xy):
    """Shoelace area of a polygon given by its corners in order."""
    x, y = np.asarray(xy).T
    return 0.5 * abs(x @ np.roll(y, -1) - y @ np.roll(x, -1))


def test_from_halfspaces_box_and_redundant_rows():
    box = ConvexPolytope.box([0.8, 1.2, 0.5])
    from_planes = ConvexPolytope.from_halfspaces(box.A, box.b)
    assert _same_point_sets(from_planes.vertices, box.vertices)
    # A redundant row is kept in (A, b) exactly as given but adds no vertex.
    A = np.vstack([box.A, [[1.0, 1.0, 0.0]]])
    b = np.append(box.b, 5.0)
    with_redundant = ConvexPolytope.from_halfspaces(A, b)
    assert np.array_equal(with_redundant.A, A) and np.array_equal(with_redundant.b, b)
    assert _same_point_sets(with_redundant.vertices, box.vertices)


def test_from_halfspaces_merges_an_apex_where_four_planes_meet():
    # Square pyramid: base z >= 0 on [-1, 1]^2, apex (0, 0, 1) on the four slanted faces
    # +-x + z <= 1, +-y + z <= 1. Qhull reports the apex once per dual facet; it must be kept once.
    A = [[1, 0, 1], [-1, 0, 1], [0, 1, 1], [0, -1, 1], [0, 0, -1]]
    pyramid = ConvexPolytope.from_halfspaces(A, [1.0, 1.0, 1.0, 1.0, 0.0])
    expected = [[1, 1, 0], [1, -1, 0], [-1, 1, 0], [-1, -1, 0], [0, 0, 1]]
    assert _same_point_sets(pyramid.vertices, expected)


def test_soft_capture_target_hull():
    # Pentagonal prism |z| <= 1.2; its corners solved by hand from pairs of rows, e.g.
    # x + 3y = 4.53 with 3x - 3.6y = 13.5 gives y = 0.09 / 12.6, x = 4.53 - 3y.
    hull = soft_capture_target_hull()
    A = [[0, 0, 1], [0, 0, -1], [0, 1, 0], [-1, 3, 0], [-3, -3.6, 0], [1, 3, 0], [3, -3.6, 0]]
    assert np.array_equal(hull.A, A)
    assert np.array_equal(hull.b, [1.2, 1.2, 1.2, 4.53, 13.5, 4.53, 13.5])
    y_side = 0.09 / 12.6
    pentagon = [(0.0, -3.75), (4.53 - 3 * y_side, y_side), (0.93, 1.2), (-0.93, 1.2)]
    pentagon.append((-(4.53 - 3 * y_side), y_side))
    expected = [(x, y, z) for x, y in pentagon for z in (-1.2, 1.2)]
    assert _same_point_sets(hull.vertices, expected, atol=1e-12)
    # Volume from the Qhull hull of the computed vertices against area x height by hand.
    assert ConvexHull(hull.vertices).volume == pytest.approx(_polygon_area(pentagon) * 2.4)
    assert np.all(hull.b > 0.0)  # origin strictly inside, as the collision metric needs


def test_soft_capture_chaser_hull():
    # Hexagonal prism z in [-1.2, 1.2099], |x| <= 1.2099, 2|x| + |y| <= 3.6.
    hull = soft_capture_chaser_hull()
    assert np.array_equal(hull.b, [1.2099, 1.2, 1.2099, 1.2099, 3.6, 3.6, 3.6, 3.6])
    y_corner = 3.6 - 2.0 * 1.2099
    hexagon = [(0.0, 3.6), (1.2099, y_corner), (1.2099, -y_corner), (0.0, -3.6)]
    hexagon += [(-1.2099, -y_corner), (-1.2099, y_corner)]
    expected = [(x, y, z) for x, y in hexagon for z in (-1.2, 1.2099)]
    assert _same_point_sets(hull.vertices, expected, atol=1e-12)
    assert ConvexHull(hull.vertices).volume == pytest.approx(_polygon_area(hexagon) * 2.4099)


def test_from_halfspaces_rejects_unbounded_empty_and_flat_sets():
    box = ConvexPolytope.box([1.0, 1.0, 1.0])  # rows +x, +y, +z, -x, -y, -z
    assert halfspaces_are_bounded(box.A)
    # An uncapped square prism (no z rows) and a box missing its -z face are unbounded.
    with pytest.raises(ValueError, match="unbounded"):
        ConvexPolytope.from_halfspaces(box.A[[0, 1, 3, 4]], box.b[[0, 1, 3, 4]])
    assert not halfspaces_are_bounded(box.A[:5])  # -z missing: open towards -z
    # x <= -1 and x >= 1: empty; x <= 0 and x >= 0: a flat square with no interior.
    with pytest.raises(ValueError, match="empty"):
        ConvexPolytope.from_halfspaces(box.A, [-1.0, 1.0, 1.0, -1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="no interior"):
        ConvexPolytope.from_halfspaces(box.A, [0.0, 1.0, 1.0, 0.0, 1.0, 1.0])


# ---- ContactTest: the safety monitor's per-step separating-axis test ------------------------


def _sampled_penetration(shape_a, R_a, p_a, shape_b, R_b, p_b, directions):
    """The least overlap of the projections over many sampled unit directions: for convex
    shapes the penetration depth is the minimum over all directions, so this is an upper
    bound on it that tightens as the sampling gets denser (independent of the SAT axes)."""
    Va = shape_a.vertices @ R_a.matrix().T + p_a
    Vb = shape_b.vertices @ R_b.matrix().T + p_b
    pa, pb = directions @ Va.T, directions @ Vb.T
    overlap = np.minimum(pa.max(1) - pb.min(1), pb.max(1) - pa.min(1))
    return float(np.min(overlap))


def test_edge_directions_of_a_box_and_the_soft_capture_hulls():
    assert len(edge_directions(ConvexPolytope.box([1.0, 2.0, 3.0]))) == 3
    # Prisms: the polygon's edge directions plus the prism axis (opposite edges parallel).
    assert len(edge_directions(soft_capture_chaser_hull())) == 4  # hexagon: 3 pairs + z
    assert len(edge_directions(soft_capture_target_hull())) == 6  # pentagon: 5 + z


def test_contact_depth_of_offset_boxes_is_the_overlap():
    test = ContactTest(ConvexPolytope.box([1.0, 1.0, 1.0]), ConvexPolytope.box([1.0, 1.0, 1.0]))
    assert test.depth(IDENTITY, ORIGIN, IDENTITY, [0.8, 0.1, 0.0]) == pytest.approx(0.2)
    assert test.depth(IDENTITY, ORIGIN, IDENTITY, [1.0, 0.0, 0.0]) == pytest.approx(0.0)
    assert test.depth(IDENTITY, ORIGIN, IDENTITY, [1.3, 0.0, 0.0]) == pytest.approx(-0.3)


@pytest.mark.parametrize("pair", ["boxes", "soft_capture_hulls"])
def test_contact_depth_agrees_with_separation_and_with_sampled_directions(pair):
    rng = np.random.default_rng(11)
    if pair == "boxes":
        a, b = ConvexPolytope.box([1.0, 2.0, 3.0]), ConvexPolytope.box([0.6, 0.4, 1.5])
        reach = (0.5, 3.5)
    else:
        a, b = soft_capture_target_hull(), soft_capture_chaser_hull()
        reach = (2.0, 9.0)
    test = ContactTest(a, b)
    directions = rng.normal(size=(40000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    n_apart = n_overlapping = 0
    for _ in range(30):
        R_a, R_b = _random_rotation(rng), _random_rotation(rng)
        p_a = rng.uniform(-1.0, 1.0, 3)
        direction = rng.normal(size=3)
        p_b = p_a + rng.uniform(*reach) * direction / np.linalg.norm(direction)
        depth = test.depth(R_a, p_a, R_b, p_b)
        distance = separation_distance(a, R_a, p_a, b, R_b, p_b)
        if depth < 0.0:
            n_apart += 1
            # Apart: the SOCP distance is positive and at least the SAT gap.
            assert distance > 0.0 and -depth <= distance + TOL
        else:
            n_overlapping += 1
            assert distance == 0.0
            # The SAT depth is the minimum over all directions: never above a sampled one, and
            # within the sampling's resolution of the best of 40,000 directions (~1 % of the
            # bodies' metre sizes).
            sampled = _sampled_penetration(a, R_a, p_a, b, R_b, p_b, directions)
            assert depth <= sampled + 1e-12
            assert sampled - depth < 0.03
    assert n_apart >= 5 and n_overlapping >= 5
