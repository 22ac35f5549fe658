"""Convex polytopes and the Euclidean separation distance between two posed polytopes.

Owns: the ``ConvexPolytope`` description (halfspaces and vertices in the body frame), its
constructors (box, convex hull of points, intersection of halfspaces), the soft-capture hulls of
paper 000 (``soft_capture_target_hull``, ``soft_capture_chaser_hull``), and
``separation_distance`` used by the safety monitor. Does not own: meshes for visualisation, the
differentiable collision metric of the planners (paper 000 Sec. II-B, DCOL's inflation factor,
in ``rpod.models.collision``).

``ContactTest`` is the cheap contact check of the safety monitor, run at every integrator step:
the separating-axis test of two posed polytopes. Two convex polytopes are disjoint iff some
axis among the face normals of either and the cross products of an edge direction of each
separates their projections (Gottschalk, Lin and Manocha, OBBTree, SIGGRAPH 1996; the general
polytope form in Ericson, Real-Time Collision Detection, 2005, Sec. 5.2.1). The least overlap
of the projections over those axes is, when they intersect, the penetration depth: the
shortest translation that separates them (the Minkowski difference of two polytopes has only
face-vertex and edge-edge faces, whose normals are exactly these axes). When they are apart,
minus the largest gap over the axes is a lower bound on the distance (its sign is exact).
Numpy on small arrays: ~20-40 us for two boxes (15 axes), no solver.

``separation_distance`` solves the minimum-distance problem over convex combinations of the
posed vertices, written as a small second-order cone program,

    min s  s.t.  |d| <= s,  d = sum_i lam_i a_i - sum_j mu_j b_j,
                 lam, mu >= 0,  sum lam = sum mu = 1,

with ``ClarabelSolver`` (an interior-point conic solver from pydrake.solvers, named explicitly,
tolerances 1e-12). The cone form, rather than the QP ``min |d|^2``, matters: the solver's
tolerance then applies to the distance itself, not to its square, so bodies in contact come
out at ~1e-13 m instead of ~sqrt(1e-12) = 1e-6 m. One ``MathematicalProgram`` is built per pair
of vertex counts and cached; a call only updates the coefficients of the pose-dependent
equality constraint and costs ~0.15-0.3 ms for two boxes. The cache makes the function
not thread-safe (separate processes, as in campaigns, are fine).
"""

from dataclasses import dataclass

import numpy as np
from pydrake.math import RotationMatrix
from pydrake.solvers import ClarabelSolver, MathematicalProgram, SolverOptions


@dataclass(frozen=True)
class ConvexPolytope:
    """A bounded convex polytope in its body frame P.

    Attributes:
        A: Outward face normals (m, 3); the polytope is ``{p_PQ : A p_PQ <= b}``.
        b: Face offsets (m,) [m].
        vertices: Vertices (V, 3) expressed in P [m]; their convex hull equals the halfspace set.
    """

    A: np.ndarray
    b: np.ndarray
    vertices: np.ndarray

    def __post_init__(self):
        A = np.asarray(self.A, dtype=float)
        b = np.asarray(self.b, dtype=float).reshape(-1)
        vertices = np.asarray(self.vertices, dtype=float)
        if A.ndim != 2 or A.shape[1] != 3 or b.shape != (A.shape[0],):
            raise ValueError(f"A must be (m, 3) and b (m,), got {A.shape} and {b.shape}")
        if vertices.ndim != 2 or vertices.shape[1] != 3 or vertices.shape[0] < 1:
            raise ValueError(f"vertices must be (V, 3) with V >= 1, got {vertices.shape}")
        scale = max(1.0, float(np.max(np.abs(vertices))))
        if np.any(vertices @ A.T > b + 1e-9 * scale):
            raise ValueError("some vertices lie outside the halfspaces A p <= b")
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "b", b)
        object.__setattr__(self, "vertices", vertices)

    @classmethod
    def box(cls, size_xyz) -> "ConvexPolytope":
        """An axis-aligned box centred on the body origin.

        Args:
            size_xyz: Full edge lengths (3,) along body x, y, z [m], all > 0.
        """
        half = 0.5 * np.asarray(size_xyz, dtype=float).reshape(-1)
        if half.shape != (3,) or not np.all(half > 0.0):
            raise ValueError(f"box size must be 3 positive lengths, got {size_xyz}")
        A = np.vstack([np.eye(3), -np.eye(3)])
        b = np.concatenate([half, half])
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        return cls(A=A, b=b, vertices=signs * half)

    @classmethod
    def from_vertices(cls, vertices) -> "ConvexPolytope":
        """The convex hull of a 3-D point set (interior points are dropped).

        Args:
            vertices: Points (N, 3) in the body frame [m], not all coplanar.
        """
        points = np.asarray(vertices, dtype=float)
        from scipy.spatial import ConvexHull  # at use: every rpod process starts ~0.25 s sooner

        hull = ConvexHull(points)
        # hull.equations rows are [n, c] with n . p + c <= 0 inside and |n| = 1.
        return cls(A=hull.equations[:, :3], b=-hull.equations[:, 3], vertices=points[hull.vertices])

    @classmethod
    def from_halfspaces(cls, A, b) -> "ConvexPolytope":
        """The bounded polytope ``{p_PQ : A p_PQ <= b}``, its vertices computed by Qhull.

        ``A`` and ``b`` are kept exactly as given (rows need not be unit, redundant rows are
        kept), so a caller's LP data stay byte-identical. The vertices come from
        ``scipy.spatial.HalfspaceIntersection`` about the Chebyshev centre (the centre of the
        largest inscribed ball, found by ``scipy.optimize.linprog``), and are then reduced to the
        extreme points of their convex hull (Qhull returns one point per dual facet, so a vertex
        where more than three planes meet, as at a pyramid's apex, would otherwise repeat).

        Args:
            A: Face normals (m, 3), m >= 4, need not be normalised.
            b: Offsets (m,) [m].

        Raises:
            ValueError: If the set is unbounded (the rows of ``A`` do not positively span R^3),
                empty, or flat (no interior), or the shapes are wrong.
        """
        A = np.asarray(A, dtype=float)
        b = np.asarray(b, dtype=float).reshape(-1)
        if A.ndim != 2 or A.shape[1] != 3 or b.shape != (A.shape[0],):
            raise ValueError(f"A must be (m, 3) and b (m,), got {A.shape} and {b.shape}")
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
            raise ValueError("A and b must be finite")
        if not halfspaces_are_bounded(A):
            raise ValueError("the halfspaces A p <= b do not bound a polytope (unbounded set)")
        # Chebyshev centre: max r s.t. a_i . c + r |a_i| <= b_i; the set is bounded, so r is.
        row_norms = np.linalg.norm(A, axis=1)
        from scipy.optimize import linprog  # at use: every rpod process starts ~0.25 s sooner
        from scipy.spatial import ConvexHull, HalfspaceIntersection

        lp = linprog(
            c=[0.0, 0.0, 0.0, -1.0],
            A_ub=np.column_stack([A, row_norms]),
            b_ub=b,
            bounds=[(None, None)] * 3 + [(0.0, None)],
            method="highs",
        )
        if lp.status == 2:
            raise ValueError("the halfspaces A p <= b are empty (infeasible)")
        if lp.status != 0 or lp.x[3] <= 1e-9 * max(1.0, float(np.max(np.abs(b)))):
            raise ValueError("the halfspaces A p <= b have no interior (flat set)")
        intersection = HalfspaceIntersection(np.column_stack([A, -b]), lp.x[:3])
        points = intersection.intersections
        return cls(A=A, b=b, vertices=points[ConvexHull(points).vertices])


def edge_directions(polytope: ConvexPolytope, tolerance: float = 1e-9) -> np.ndarray:
    """The unit directions (E, 3) of a polytope's edges, one per parallel class (sign-free).

    An edge joins two vertices that lie on two faces of different normals; its direction is
    that of the faces' intersection line.
    """
    V, A, b = polytope.vertices, polytope.A, polytope.b
    scale = max(1.0, float(np.max(np.abs(V))))
    normals = A / np.linalg.norm(A, axis=1)[:, None]
    on_face = np.abs(V @ A.T - b) <= tolerance * scale * np.linalg.norm(A, axis=1)  # (V, m)
    directions = []
    for i in range(len(V)):
        for k in range(i + 1, len(V)):
            shared = np.flatnonzero(on_face[i] & on_face[k])
            if len(shared) < 2:
                continue
            n_shared = normals[shared]
            if np.linalg.matrix_rank(n_shared, tol=1e-9) < 2:
                continue  # the same plane twice (a redundant row), not an edge
            d = V[k] - V[i]
            d = d / np.linalg.norm(d)
            if not any(abs(float(d @ e)) > 1.0 - 1e-9 for e in directions):
                directions.append(d)
    return np.array(directions).reshape(-1, 3)


class ContactTest:
    """Whether two posed polytopes touch, and how deep (the module docstring's SAT).

    Built once per pair of shapes (the face normals and edge directions of each, in their own
    frames); `depth` then costs a few small numpy products per call.
    """

    def __init__(self, shape_a: ConvexPolytope, shape_b: ConvexPolytope):
        """Args: shape_a, shape_b: the two polytopes, each in its own frame."""
        self._Va = shape_a.vertices
        self._Vb = shape_b.vertices
        self._Na = _unique_unit_rows(shape_a.A)
        self._Nb = _unique_unit_rows(shape_b.A)
        self._Ea = edge_directions(shape_a)
        self._Eb = edge_directions(shape_b)
        # Bounding radii about each frame's origin: farther apart than their sum, no contact.
        self.bounding_radius_sum_m = float(
            np.max(np.linalg.norm(self._Va, axis=1)) + np.max(np.linalg.norm(self._Vb, axis=1))
        )

    def depth(self, R_Wa, p_Wa, R_Wb, p_Wb) -> float:
        """The least overlap of the projections over the separating axes [m].

        > 0: the shapes intersect, by this penetration depth; 0: they touch; < 0: they are
        apart (minus a lower bound on their distance).
        """
        R_Wa, R_Wb = _rotation_matrix(R_Wa), _rotation_matrix(R_Wb)
        p_Wa = np.asarray(p_Wa, dtype=float)
        p_Wb = np.asarray(p_Wb, dtype=float)
        if float(np.linalg.norm(p_Wa - p_Wb)) > self.bounding_radius_sum_m:
            return -(float(np.linalg.norm(p_Wa - p_Wb)) - self.bounding_radius_sum_m)
        Ea, Eb = self._Ea @ R_Wa.T, self._Eb @ R_Wb.T
        crosses = np.cross(Ea[:, None, :], Eb[None, :, :]).reshape(-1, 3)
        norms = np.linalg.norm(crosses, axis=1)
        crosses = crosses[norms > 1e-9] / norms[norms > 1e-9, None]
        axes = np.vstack([self._Na @ R_Wa.T, self._Nb @ R_Wb.T, crosses])
        proj_a = axes @ (self._Va @ R_Wa.T + p_Wa).T  # (k, Va)
        proj_b = axes @ (self._Vb @ R_Wb.T + p_Wb).T
        overlap = np.minimum(
            proj_a.max(axis=1) - proj_b.min(axis=1), proj_b.max(axis=1) - proj_a.min(axis=1)
        )
        return float(np.min(overlap))


def _unique_unit_rows(A) -> np.ndarray:
    """The rows of A normalised, opposite and repeated directions dropped (same axis)."""
    rows = []
    for a in np.asarray(A, dtype=float):
        a = a / np.linalg.norm(a)
        if not any(abs(float(a @ r)) > 1.0 - 1e-12 for r in rows):
            rows.append(a)
    return np.array(rows)


def halfspaces_are_bounded(A) -> bool:
    """Whether every non-empty set ``{p : A p <= b}`` is bounded, i.e. ``A d <= 0`` only for d = 0.

    That holds iff the rows of ``A`` positively span R^3, i.e. the origin lies strictly inside
    the convex hull of the rows (Gordan's alternative), which is what is tested.

    Args:
        A: Face normals (m, 3).
    """
    A = np.asarray(A, dtype=float)
    norms = np.linalg.norm(A, axis=1)
    if A.ndim != 2 or A.shape[1] != 3 or A.shape[0] < 4 or np.any(norms == 0.0):
        return False
    from scipy.spatial import ConvexHull, QhullError  # at use: rpod starts ~0.25 s sooner

    try:
        hull = ConvexHull(A / norms[:, None])  # normalised rows: the test is scale-free
    except QhullError:  # all rows coplanar: a prism without caps, a slab, ...
        return False
    # hull.equations rows [n, c], n . y + c <= 0 inside: the origin is interior iff every c < 0.
    return bool(np.all(hull.equations[:, 3] < -1e-12))


# Convex hulls of paper 000's soft-capture bodies, in their body frames (A y <= b, metres), from
# the authors' public code (RoboticExplorationLab/SoftCapture), as quoted in rpod issue 4. Both
# contain their body origin (the centre of mass) strictly, as the collision metric requires.
_SOFT_CAPTURE_TARGET_A = [
    [0.0, 0.0, 1.0],
    [0.0, 0.0, -1.0],
    [0.0, 1.0, 0.0],
    [-1.0, 3.0, 0.0],
    [-3.0, -3.6, 0.0],
    [1.0, 3.0, 0.0],
    [3.0, -3.6, 0.0],
]
_SOFT_CAPTURE_TARGET_B = [1.2, 1.2, 1.2, 4.53, 13.5, 4.53, 13.5]
_SOFT_CAPTURE_CHASER_A = [
    [0.0, 0.0, 1.0],
    [0.0, 0.0, -1.0],
    [1.0, 0.0, 0.0],
    [-1.0, 0.0, 0.0],
    [2.0, 1.0, 0.0],
    [2.0, -1.0, 0.0],
    [-2.0, 1.0, 0.0],
    [-2.0, -1.0, 0.0],
]
_SOFT_CAPTURE_CHASER_B = [1.2099, 1.2, 1.2099, 1.2099, 3.6, 3.6, 3.6, 3.6]


def soft_capture_target_hull() -> ConvexPolytope:
    """Paper 000's target hull in frame T: a pentagonal prism, |z| <= 1.2 m, 10 vertices.

    Its cross-section is the pentagon y <= 1.2, -x + 3y <= 4.53, x + 3y <= 4.53,
    -3x - 3.6y <= 13.5, 3x - 3.6y <= 13.5, with corners (0, -3.75), (+-4.5086, 0.0071) and
    (+-0.93, 1.2) m (the y <= 1.2 row cuts the apex (0, 1.51) of the two slanted upper rows).
    The capture point D_t = [0, 0, 2.7] m lies 1.5 m beyond its +z face.
    """
    return ConvexPolytope.from_halfspaces(_SOFT_CAPTURE_TARGET_A, _SOFT_CAPTURE_TARGET_B)


def soft_capture_chaser_hull() -> ConvexPolytope:
    """Paper 000's chaser hull in frame C: a hexagonal prism, z in [-1.2, 1.2099] m, 12 vertices.

    Its cross-section is the hexagon |x| <= 1.2099, 2|x| + |y| <= 3.6 (corners at
    (+-1.2099, +-1.1802) and (0, +-3.6) m). The capture point D_c = [0, 0, 2.7] m lies ~1.49 m
    beyond its +z face.
    """
    return ConvexPolytope.from_halfspaces(_SOFT_CAPTURE_CHASER_A, _SOFT_CAPTURE_CHASER_B)


class _DistanceProgram:
    """The cached minimum-distance SOCP for polytopes with ``na`` and ``nb`` vertices."""

    def __init__(self, na: int, nb: int):
        self.prog = MathematicalProgram()
        self.d = self.prog.NewContinuousVariables(3, "d")
        lam = self.prog.NewContinuousVariables(na, "lam")
        mu = self.prog.NewContinuousVariables(nb, "mu")
        self.prog.AddBoundingBoxConstraint(0.0, np.inf, lam)
        self.prog.AddBoundingBoxConstraint(0.0, np.inf, mu)
        self.prog.AddLinearEqualityConstraint(np.ones((1, na)), [1.0], lam)
        self.prog.AddLinearEqualityConstraint(np.ones((1, nb)), [1.0], mu)
        s = self.prog.NewContinuousVariables(1, "s")
        self.prog.AddLorentzConeConstraint(np.concatenate([s, self.d]))  # |d| <= s
        self.prog.AddLinearCost([1.0], s)
        # d - R_Wa Va^T lam + R_Wb Vb^T mu = p_Wa - p_Wb; coefficients set per call.
        self.A_eq = np.zeros((3, 3 + na + nb))
        self.A_eq[:, :3] = np.eye(3)
        self.pose_constraint = self.prog.AddLinearEqualityConstraint(
            self.A_eq, np.zeros(3), np.concatenate([self.d, lam, mu])
        ).evaluator()
        self.na = na


_SOLVER = ClarabelSolver()
_OPTIONS = SolverOptions()
for _name in ("tol_gap_abs", "tol_gap_rel", "tol_feas"):
    _OPTIONS.SetOption(ClarabelSolver.id(), _name, 1e-12)
_PROGRAMS: dict[tuple[int, int], _DistanceProgram] = {}
# Distances below this are reported as exactly 0 (contact or overlap): the solver's residual
# on touching or overlapping polytopes is ~1e-13 m, and 1 nm is far below any clearance.
_CONTACT_TOLERANCE = 1e-9


def _rotation_matrix(R) -> np.ndarray:
    return R.matrix() if isinstance(R, RotationMatrix) else np.asarray(R, dtype=float)


def separation_distance(
    shape_a: ConvexPolytope, R_Wa, p_Wa, shape_b: ConvexPolytope, R_Wb, p_Wb
) -> float:
    """Euclidean distance between two posed convex polytopes, 0 when they touch or overlap.

    Overlap returns 0 (no negative penetration depth is computed); distances below 1e-9 m
    are reported as exactly 0. Accuracy ~1e-10 m for metre-sized bodies.

    Args:
        shape_a: Polytope a, described in its frame a.
        R_Wa: Orientation of frame a in the common frame W (``RotationMatrix`` or 3x3 array).
        p_Wa: Position (3,) of frame a's origin in W [m].
        shape_b: Polytope b, described in its frame b.
        R_Wb: Orientation of frame b in W.
        p_Wb: Position (3,) of frame b's origin in W [m].

    Returns:
        The distance [m].

    Raises:
        RuntimeError: If Clarabel does not report success (not expected for this small,
            always-feasible problem; the message carries the solver's status).
    """
    key = (len(shape_a.vertices), len(shape_b.vertices))
    program = _PROGRAMS.get(key)
    if program is None:
        program = _PROGRAMS[key] = _DistanceProgram(*key)
    na = program.na
    program.A_eq[:, 3 : 3 + na] = -(_rotation_matrix(R_Wa) @ shape_a.vertices.T)
    program.A_eq[:, 3 + na :] = _rotation_matrix(R_Wb) @ shape_b.vertices.T
    p_ab_W = np.asarray(p_Wa, dtype=float) - np.asarray(p_Wb, dtype=float)
    program.pose_constraint.UpdateCoefficients(program.A_eq, p_ab_W)
    result = _SOLVER.Solve(program.prog, None, _OPTIONS)
    if not result.is_success():
        raise RuntimeError(
            f"separation_distance: Clarabel returned {result.get_solution_result()} "
            f"({result.get_solver_details().status})"
        )
    distance = float(np.linalg.norm(result.GetSolution(program.d)))
    return distance if distance > _CONTACT_TOLERANCE else 0.0
