"""The scene's polytope bodies and the planned-path overlay.

Truths: the hull mesh of paper 000's target (a pentagonal prism) encloses exactly the prism's
volume (shoelace area of its pentagon times its 2.4 m height, computed here by hand), with every
triangle wound outward; SceneGraph holds a Convex shape for a body given by vertices and a Box
otherwise; the overlay shows each plan from its own time on and hides the one it replaces.
"""

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.geometry import Box, Convex, SceneGraph

from rpod.models.shapes import soft_capture_chaser_hull, soft_capture_target_hull
from rpod.systems.plan_at_start import PlannedPath
from rpod.systems.scene import (
    PlannedPathOverlay,
    RendezvousScene,
    SceneConfig,
    SceneGeometry,
    convex_hull_obj,
)


def _triangles(obj: str) -> np.ndarray:
    vertices, faces = [], []
    for line in obj.splitlines():
        kind, *rest = line.split()
        if kind == "v":
            vertices.append([float(v) for v in rest])
        elif kind == "f":
            faces.append([int(i) - 1 for i in rest])
    return np.asarray(vertices)[np.asarray(faces)]


def test_hull_mesh_of_the_target_encloses_the_prism_volume_and_faces_outward():
    triangles = _triangles(convex_hull_obj(soft_capture_target_hull().vertices))
    # Divergence theorem: V = sum over outward triangles of a . (b x c) / 6.
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    signed = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    pentagon = np.array([[0.0, -3.75], [4.5086, 0.0071], [0.93, 1.2], [-0.93, 1.2],
                         [-4.5086, 0.0071]])  # fmt: skip
    x, y = pentagon.T
    area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    # The corners are quoted to 1e-4 m (shapes.py docstring): the areas agree to ~1e-3 relative.
    assert signed.sum() == pytest.approx(area * 2.4, rel=2e-3)
    # Outward: each triangle's normal points away from the centroid (the body origin is inside).
    normals = np.cross(b - a, c - a)
    assert np.all(np.einsum("ij,ij->i", normals, (a + b + c) / 3.0) > 0.0)


def test_a_body_given_by_vertices_is_registered_as_its_convex_hull():
    scene_graph = SceneGraph()
    geometry = SceneGeometry(
        target_vertices_T=soft_capture_target_hull().vertices.tolist(),
        chaser_vertices_C=soft_capture_chaser_hull().vertices.tolist(),
    )
    scene = RendezvousScene(scene_graph, _Recorder(), SceneConfig(), geometry)
    inspector = scene_graph.model_inspector()
    for frame_id in (scene.target_frame_id(), scene.chaser_frame_id()):
        shapes = [inspector.GetShape(g) for g in inspector.GetGeometries(frame_id)]
        assert sum(isinstance(s, Convex) for s in shapes) == 1
        assert not any(isinstance(s, Box) for s in shapes)
    hull = next(inspector.GetShape(g) for g in inspector.GetGeometries(scene.target_frame_id())
                if isinstance(inspector.GetShape(g), Convex))  # fmt: skip
    assert hull.GetConvexHull().num_vertices() == 10  # the pentagonal prism
    # Without vertices the boxes stay (the path test_scene.py covers).
    scene_graph = SceneGraph()
    boxes = RendezvousScene(scene_graph, _Recorder(), SceneConfig())
    inspector = scene_graph.model_inspector()
    shapes = [inspector.GetShape(g) for g in inspector.GetGeometries(boxes.target_frame_id())]
    assert sum(isinstance(s, Box) for s in shapes) == 1


class _Recorder:
    """A stand-in Meshcat that records calls."""

    def __init__(self):
        self.calls = []

    def __getattr__(self, name):
        return lambda *args, **kwargs: self.calls.append((name, args, kwargs))


def test_the_overlay_shows_each_plan_from_its_time_and_hides_the_replaced_one():
    meshcat = _Recorder()
    overlay = PlannedPathOverlay(meshcat, publish_period_s=0.5)
    context = overlay.CreateDefaultContext()
    port = overlay.GetInputPort("planned_path")
    path = np.array([[10.0, 0.0, 0.0], [8.0, 1.0, 0.0], [6.0, 1.5, 0.0]])
    port.FixValue(context, AbstractValue.Make(PlannedPath(1, 0.0, path)))
    overlay._Initialize(context)
    context.SetTime(1.0)
    overlay.PublishScene(context)  # same plan: nothing new
    context.SetTime(10.0)
    port.FixValue(context, AbstractValue.Make(PlannedPath(2, 10.0, path[1:])))
    overlay.PublishScene(context)

    lines = [args for name, args, _ in meshcat.calls if name == "SetLine"]
    assert [args[0] for args in lines] == ["rpod/overlay/plans/001/line",
                                           "rpod/overlay/plans/002/line"]  # fmt: skip
    np.testing.assert_array_equal(lines[0][1], path.T)
    visible = [(args[0], args[2], kwargs["time_in_recording"])
               for name, args, kwargs in meshcat.calls if name == "SetProperty"]  # fmt: skip
    assert visible == [
        ("rpod/overlay/plans/001", False, 0.0), ("rpod/overlay/plans/001", True, 0.0),
        ("rpod/overlay/plans/002", False, 0.0), ("rpod/overlay/plans/002", True, 10.0),
        ("rpod/overlay/plans/001", False, 10.0),
    ]  # fmt: skip
