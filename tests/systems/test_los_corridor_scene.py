"""Paper 004's LOS corridor in the Meshcat scene (rpod.systems.los_corridor_scene).

Truths: the drawn frustum is the constraint set { A_c p <= b_c, y_T <= length }: its vertices
satisfy A_c p <= b_c to 1e-9 and each lies on three of its planes, its edges open at
atan(tan(alpha_c) / cos(pi / n_f)) (the model's docstring: 32.0 deg for 30 deg and 8 faces), the
registered mesh holds exactly the points the corridor holds, and its volume is that of a regular
n_f-gon frustum with apothem y tan(alpha_c), by hand; the frustum, its edges and the hold point
are on the target frame, so their poses in a diagram context are the target's pose times their
fixed poses in T, with X_LT = R_IL^T R_IT computed here with scipy.
"""

import numpy as np
import pytest
from pydrake.geometry import Convex, Role, Sphere
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from rpod.diagrams.recording import make_headless_meshcat
from rpod.models.los_corridor import LosCorridor
from rpod.systems.los_corridor_scene import (
    add_los_corridor_to_scene,
    los_corridor_edge_directions,
    los_corridor_frustum_vertices,
)
from rpod.systems.scene import RendezvousScene, SceneConfig
from rpod.systems.sensed import sensed_vector

LENGTH_M = 20.0
P_TH_T = np.array([0.5, 12.0, -0.8])
CORRIDORS = [
    LosCorridor(),  # paper 004 Table 1: 30 deg, 8 faces, floor 1 m
    LosCorridor(half_angle_rad=np.radians(20.0), faces=5, floor_m=2.5),
    LosCorridor(half_angle_rad=np.radians(45.0), faces=6, floor_m=0.0),
]


def _wxyz(rotation: Rotation) -> np.ndarray:
    x, y, z, w = rotation.as_quat()
    return np.array([w, x, y, z])


def _planes(corridor: LosCorridor, length_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(A, b): the corridor's rows, then the cap y_T <= length_m."""
    return np.vstack([corridor.A_c, [0.0, 1.0, 0.0]]), np.r_[corridor.b_c, length_m]


@pytest.mark.parametrize("corridor", CORRIDORS)
def test_frustum_vertices_are_corners_of_the_constraint_set(corridor):
    vertices = los_corridor_frustum_vertices(corridor, LENGTH_M)
    # A floor ring and a cap ring, or the apex and the cap ring when the floor is at 0.
    assert len(vertices) == corridor.faces + (1 if corridor.floor_m == 0.0 else corridor.faces)
    A, b = _planes(corridor, LENGTH_M)
    slack = b - vertices @ A.T
    assert np.all(slack >= -1e-9)
    # A corner of a 3-D polytope: on at least three of its planes (two faces and floor or cap).
    assert np.all(np.sum(np.abs(slack) <= 1e-9, axis=1) >= 3)
    # The edges open at atan(tan(alpha_c) / cos(pi / n_f)) from +y_T, n_f of them.
    directions = los_corridor_edge_directions(corridor)
    assert len(directions) == corridor.faces
    expected = np.arctan(np.tan(corridor.half_angle_rad) / np.cos(np.pi / corridor.faces))
    np.testing.assert_allclose(np.arccos(directions[:, 1]), expected, atol=1e-12)


def test_default_corridor_edges_open_at_32_degrees():
    angles = np.degrees(np.arccos(los_corridor_edge_directions(LosCorridor())[:, 1]))
    np.testing.assert_allclose(angles, 32.0, atol=0.01)


def test_a_cut_at_or_below_the_floor_is_refused():
    with pytest.raises(ValueError, match="length_m"):
        los_corridor_frustum_vertices(LosCorridor(floor_m=1.0), 1.0)


def _build(corridor: LosCorridor, R_IL: Rotation, R_IT: Rotation):
    meshcat = make_headless_meshcat()
    builder = DiagramBuilder()
    sensed = sensed_vector(
        np.r_[3.0, 15.0, -2.0, 0.0, 0.0, 0.0],
        _wxyz(R_IL),
        np.zeros(3),
        np.r_[_wxyz(R_IT), 0.0, 0.0, 0.1],
        np.r_[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    )
    source = builder.AddSystem(ConstantVectorSource(sensed))
    scene = RendezvousScene.AddToBuilder(builder, meshcat, SceneConfig(), source.get_output_port())
    ids = add_los_corridor_to_scene(scene, corridor, LENGTH_M, P_TH_T)
    scene_graph = builder.GetSubsystemByName("scene.scene_graph")
    diagram = builder.Build()
    return meshcat, diagram, scene, scene_graph, ids


@pytest.mark.parametrize("corridor", CORRIDORS)
def test_the_registered_mesh_holds_exactly_the_corridors_points(corridor):
    _, _, _, scene_graph, ids = _build(corridor, Rotation.identity(), Rotation.identity())
    shape = scene_graph.model_inspector().GetShape(ids["los_corridor"])
    assert isinstance(shape, Convex)
    mesh = shape.GetConvexHull()
    drawn = np.array([mesh.vertex(i) for i in range(mesh.num_vertices())])
    hull = ConvexHull(drawn)
    # Volume: the n_f-gon at height y has apothem y tan(alpha_c), area n_f tan(pi/n_f) apothem^2.
    n, f = corridor.faces, corridor.floor_m
    volume = n * np.tan(np.pi / n) * np.tan(corridor.half_angle_rad) ** 2 * (LENGTH_M**3 - f**3)
    assert hull.volume == pytest.approx(volume / 3.0, rel=1e-9)
    # Membership: random points clear of the boundary are in the mesh iff in the corridor cut.
    points = np.random.default_rng(4).uniform([-15.0, -1.0, -15.0], [15.0, 22.0, 15.0], (4000, 3))
    A, b = _planes(corridor, LENGTH_M)
    slack = b - points @ A.T
    clear = np.all(np.abs(slack) > 1e-6, axis=1)
    in_corridor = np.all(slack > 0.0, axis=1)
    in_mesh = np.all(points @ hull.equations[:, :3].T + hull.equations[:, 3] < 0.0, axis=1)
    np.testing.assert_array_equal(in_mesh[clear], in_corridor[clear])
    assert 200 < np.sum(in_corridor & clear) < 3800  # both sides are exercised


def test_geometry_is_on_the_target_frame_and_follows_it_into_meshcat():
    R_IL = Rotation.from_euler("zyx", [40.0, -25.0, 70.0], degrees=True)
    R_IT = Rotation.from_euler("xyz", [10.0, 80.0, -30.0], degrees=True)
    meshcat, diagram, scene, scene_graph, ids = _build(LosCorridor(), R_IL, R_IT)
    assert set(ids) == {"los_corridor", "los_corridor_hold_point"} | {
        f"los_corridor_edge_{k}" for k in range(8)
    }
    context = diagram.CreateDefaultContext()
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    inspector = query.inspector()
    R_LT = (R_IL.inv() * R_IT).as_matrix()
    X_LT = query.GetPoseInWorld(scene.target_frame_id())
    np.testing.assert_allclose(X_LT.rotation().matrix(), R_LT, atol=1e-12)
    for geometry_id in ids.values():
        assert inspector.GetFrameId(geometry_id) == scene.target_frame_id()
        X_LG = query.GetPoseInWorld(geometry_id)
        expected = X_LT @ inspector.GetPoseInFrame(geometry_id)
        np.testing.assert_allclose(X_LG.GetAsMatrix4(), expected.GetAsMatrix4(), atol=1e-12)
    # The frustum is fixed at T's origin: its pose is the target's pose.
    X_LF = query.GetPoseInWorld(ids["los_corridor"])
    np.testing.assert_allclose(X_LF.GetAsMatrix4(), X_LT.GetAsMatrix4(), atol=1e-12)
    # Translucent, illustration role, drawn by the scene's visualizer under the target.
    properties = inspector.GetProperties(ids["los_corridor"], Role.kIllustration)
    assert properties.GetProperty("phong", "diffuse").a() < 1.0
    diagram.ForcedPublish(context)
    assert meshcat.HasPath("/drake/rpod/bodies/target/los_corridor")
    assert meshcat.HasPath("/drake/rpod/bodies/target/los_corridor_hold_point")


def test_hold_point_sphere_sits_at_p_TH_T():
    R_IT = Rotation.from_euler("z", 70.0, degrees=True)
    _, diagram, _, scene_graph, ids = _build(LosCorridor(), Rotation.identity(), R_IT)
    inspector = scene_graph.model_inspector()
    hold = ids["los_corridor_hold_point"]
    assert isinstance(inspector.GetShape(hold), Sphere)
    assert inspector.GetShape(hold).radius() == pytest.approx(0.3)
    np.testing.assert_allclose(inspector.GetPoseInFrame(hold).translation(), P_TH_T, atol=0.0)
    context = diagram.CreateDefaultContext()
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    np.testing.assert_allclose(
        query.GetPoseInWorld(hold).translation(), R_IT.as_matrix() @ P_TH_T, atol=1e-12
    )
