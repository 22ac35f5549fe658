"""Paper 004's rotating LOS corridor and hold point, drawn fixed in the target frame T.

Owns: the frustum that draws `rpod.models.los_corridor.LosCorridor` (its vertices, from A_c and
b_c) and its registration, with the hold point, on the scene's target frame.
Does not own: the corridor model (rpod.models.los_corridor), the scene, its SceneGraph or its
Meshcat (rpod.systems.scene), nor paper 000's circular docking cone, which the scene draws as an
overlay of its own.

The drawn solid is the corridor cut at y_T = length_m:

    { p_T : A_c p_T <= b_c,  y_T <= length_m }                        (eq. 9 plus the cap)

The corridor's faces all pass through the origin (b_c = 0 on the face rows), so each of its
edges is a ray from the origin along n_i x n_j for two face normals (rows of A_c) whose
intersection line lies in every other face's half-space: the adjacent pairs. A ray d (d_y > 0)
meets the floor y_T = y_min at d y_min / d_y and the cap at d length_m / d_y; those 2 n_f points
(the apex alone when y_min = 0) are the vertices, and their convex hull is the frustum, which
SceneGraph draws (illustration role) through the scene's MeshcatVisualizer. Registered on the
target frame, it follows X_LT: it rotates with the target in the live view and in recordings.
"""

import itertools

import numpy as np
from pydrake.common import MemoryFile
from pydrake.geometry import Convex, Cylinder, GeometryId, InMemoryMesh, Rgba, Sphere
from pydrake.math import RigidTransform, RotationMatrix

from rpod.models.los_corridor import LosCorridor
from rpod.systems.scene import RendezvousScene, convex_hull_obj

LOS_CORRIDOR_RGBA = Rgba(0.55, 0.30, 0.85, 0.20)
LOS_CORRIDOR_EDGE_RGBA = Rgba(0.40, 0.15, 0.70, 1.0)
HOLD_POINT_RGBA = Rgba(0.95, 0.20, 0.20, 1.0)

# Two directions closer than this (unit vectors) are one edge; a slack above -this is inside.
_TOLERANCE = 1e-9


def los_corridor_edge_directions(corridor: LosCorridor) -> np.ndarray:
    """(n_f, 3) unit directions in T of the corridor's edges, ordered by angle about +y_T.

    Each is n_i x n_j of two face rows of A_c, oriented to +y_T and kept when every face row
    holds it: A_faces d <= 0 (module docstring).
    """
    faces = corridor.A_c[: corridor.faces]  # the face rows; the last row is the floor (eq. 9)
    edges = []
    for i, j in itertools.combinations(range(len(faces)), 2):
        d = np.cross(faces[i], faces[j])
        norm = np.linalg.norm(d)
        if norm < _TOLERANCE:
            continue  # parallel planes
        d = d / norm
        if d[1] < 0.0:
            d = -d
        if np.all(faces @ d <= _TOLERANCE) and not any(np.linalg.norm(d - e) < 1e-6 for e in edges):
            edges.append(d)
    edges = np.asarray(edges)
    return edges[np.argsort(np.arctan2(edges[:, 2], edges[:, 0]))]


def los_corridor_frustum_vertices(corridor: LosCorridor, length_m: float) -> np.ndarray:
    """Vertices in T [m] of the corridor cut at y_T = length_m: (2 n_f, 3), the floor ring then
    the cap ring, each ordered like `los_corridor_edge_directions`; (n_f + 1, 3) with the apex
    first when the floor is at y_T = 0."""
    if not (np.isfinite(length_m) and length_m > corridor.floor_m):
        raise ValueError(f"length_m must exceed the floor {corridor.floor_m} m, got {length_m}")
    directions = los_corridor_edge_directions(corridor)
    per_metre = directions / directions[:, 1:2]  # the edge point at y_T = 1 m
    floor = per_metre * corridor.floor_m if corridor.floor_m > 0.0 else np.zeros((1, 3))
    return np.vstack([floor, per_metre * length_m])


def add_los_corridor_to_scene(
    scene: RendezvousScene,
    corridor: LosCorridor,
    length_m: float,
    p_TH_T: np.ndarray,
    *,
    rgba: Rgba = LOS_CORRIDOR_RGBA,
    edge_rgba: Rgba | None = LOS_CORRIDOR_EDGE_RGBA,
    hold_point_rgba: Rgba = HOLD_POINT_RGBA,
    hold_point_radius_m: float | None = None,
    name: str = "los_corridor",
    R_TK: np.ndarray | None = None,
) -> dict[str, GeometryId]:
    """Registers the corridor frustum, its edges and the hold point on the scene's target frame.

    Call it after `RendezvousScene.AddToBuilder` and before a context of the diagram is made.
    Meshcat shows them under "<prefix>/bodies/target/<name>...", moving with the target.

    Args:
        scene: the scene whose target frame receives the geometry.
        corridor: the corridor model (A_c p_T <= b_c).
        length_m: where the frustum is cut, y_T = length_m [m]; above the floor.
        p_TH_T: the hold point H from the target's origin, in T (3,) [m].
        rgba: the frustum's colour (translucent by default).
        edge_rgba: the colour of thin cylinders along the n_f edges, or None for no edges.
        hold_point_rgba: the hold point sphere's colour.
        hold_point_radius_m: the sphere's radius; default max(0.3, 0.015 length_m) [m].
        name: the geometry names' stem, unique on the target frame.
        R_TK: the corridor's frame K in T when its axis is not +y_T (rpod.models.los_corridor.
            corridor_frame_R_TK); the frustum is drawn about +y_K.

    Returns:
        The GeometryIds by name: `name`, `name + "_edge_<k>"` (k = 0..n_f-1), `name +
        "_hold_point"`.
    """
    p_TH_T = np.asarray(p_TH_T, dtype=float)
    if p_TH_T.shape != (3,) or not np.all(np.isfinite(p_TH_T)):
        raise ValueError(f"p_TH_T must be 3 finite numbers, got {p_TH_T}")
    vertices_T = los_corridor_frustum_vertices(corridor, length_m)
    if R_TK is not None:
        vertices_T = vertices_T @ np.asarray(R_TK, dtype=float).T
    mesh = InMemoryMesh(mesh_file=MemoryFile(convex_hull_obj(vertices_T), ".obj", f"{name}.obj"))
    ids = {name: scene.RegisterTargetGeometry(name, Convex(mesh), RigidTransform(), rgba)}

    if edge_rgba is not None:
        n_f = corridor.faces
        floor, cap = vertices_T[:-n_f], vertices_T[-n_f:]
        edge_radius = 0.003 * length_m
        for k in range(n_f):
            start = floor[k % len(floor)]  # one apex, or one floor vertex per edge
            along = cap[k] - start
            X_TE = RigidTransform(
                RotationMatrix.MakeFromOneVector(along, 2), (start + cap[k]) / 2.0
            )
            edge = f"{name}_edge_{k}"
            ids[edge] = scene.RegisterTargetGeometry(
                edge, Cylinder(edge_radius, np.linalg.norm(along)), X_TE, edge_rgba
            )

    radius = hold_point_radius_m if hold_point_radius_m is not None else max(0.3, 0.015 * length_m)
    hold = f"{name}_hold_point"
    ids[hold] = scene.RegisterTargetGeometry(
        hold, Sphere(radius), RigidTransform(p_TH_T), hold_point_rgba
    )
    return ids
