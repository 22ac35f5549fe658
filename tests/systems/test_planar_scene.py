"""Paper 003's switching keep-out zone in the Meshcat scene (rpod.systems.planar_scene).

The outlines are checked against the model's own q of eq. 9 (rpod.models.planar_approach); the
system is driven by a chaser flying in along the turning docking normal of a target spinning
at 0.1 rad/s, so that its KOS state switches from I to II once, at a known time; a recorder
stands in for Meshcat to read the timed calls, and a real (headless) Meshcat holds every path.
"""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem

from rpod.diagrams.recording import make_headless_meshcat, start_recording
from rpod.models import planar_approach as pa
from rpod.systems.planar_scene import (
    PlanarKeepOutScene,
    add_planar_scene,
    keepout_outlines_T,
    prism_mesh,
)
from rpod.systems.scene import SceneDriver
from rpod.systems.sensed import SENSED_SIZE, sensed_vector

GEOMETRY = pa.KeepOutGeometry(0.3, 0.3)
OMEGA = 0.1  # target spin [rad/s]
PERIOD_S = 0.25
SPEED = 0.06  # inward speed along the docking normal [m/s]
SWITCH_S = (1.0 - GEOMETRY.switch_distance_m) / SPEED  # |p| = 1.5 r_safe: State I -> II


def _wxyz_z(angle):
    return np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])


class _Approach(LeafSystem):
    """The sensed bundle of a chaser at r = 1 - SPEED t on the target's docking normal, facing
    the docking face (turned by heading_error_rad from it)."""

    def __init__(self, heading_error_rad=0.0):
        super().__init__()
        self._heading_error = heading_error_rad
        self.DeclareVectorOutputPort("sensed", SENSED_SIZE, self._calc)

    def _calc(self, context, output):
        t = context.get_time()
        theta = OMEGA * t
        r = 1.0 - SPEED * t
        p = r * np.array([math.cos(theta), math.sin(theta), 0.0])
        output.SetFromVector(
            sensed_vector(
                np.r_[p, 0.0, 0.0, 0.0],
                _wxyz_z(0.0),
                np.zeros(3),
                np.r_[_wxyz_z(theta + self._heading_error), 0.0, 0.0, OMEGA],
                np.r_[_wxyz_z(theta + math.pi), 0.0, 0.0, OMEGA],
            )
        )


class _RecordingMeshcat:
    """Records the timed SetTransform / SetProperty calls and the meshes; ignores the rest."""

    def __init__(self):
        self.transforms, self.properties, self.meshes = {}, {}, {}

    def SetTransform(self, path, X, time_in_recording=None):
        if time_in_recording is not None:
            self.transforms.setdefault(path, {})[round(time_in_recording, 9)] = X

    def SetProperty(self, path, name, value, time_in_recording=None):
        if time_in_recording is not None:
            self.properties.setdefault((path, name), {})[round(time_in_recording, 9)] = value

    def SetTriangleMesh(self, path, vertices, faces, *args, **kwargs):
        self.meshes[path] = (vertices, faces)

    def __getattr__(self, name):
        return lambda *args, **kwargs: None


def _simulate(meshcat, duration_s=10.0, record=False, heading_error_rad=0.0):
    builder = DiagramBuilder()
    source = builder.AddSystem(_Approach(heading_error_rad))
    system = add_planar_scene(
        builder,
        meshcat,
        GEOMETRY,
        source.get_output_port(),
        publish_period_s=PERIOD_S,
        goal_L=np.array([0.36, 0.0]),
    )
    diagram = builder.Build()
    simulator = Simulator(diagram)
    SceneDriver.for_systems(diagram.GetSystems()).attach(simulator)
    if record:
        start_recording(meshcat)
    # The scene is drawn at step ends (SceneDriver); this diagram has no events of its own,
    # so the test ends a step at every publish time.
    simulator.Initialize()
    for t in np.arange(PERIOD_S, duration_s + 1e-9, PERIOD_S):
        simulator.AdvanceTo(t)
    return system


@pytest.mark.parametrize("state", [pa.STATE_I, pa.STATE_II])
def test_outlines_trace_the_zone_of_the_model(state):
    outlines = keepout_outlines_T(GEOMETRY, state, points_per_half=24)
    assert len(outlines) == (3 if state == pa.STATE_I else 4)
    a, b = GEOMETRY.ellipse_semi_axes_m
    c = GEOMETRY.ellipse_offset_m
    for polygon in outlines:
        # Every vertex is on the zone's boundary or inside another piece: q <= 0 (eq. 9) ...
        assert np.all(GEOMETRY.q_state(polygon, state) <= 1e-12)
        # ... and on its own piece's curve (radius, or the ellipse's quadratic form).
        r = np.hypot(polygon[:, 0], polygon[:, 1])
        on_disc = np.isclose(r, GEOMETRY.r_safe_m) | np.isclose(r, GEOMETRY.r_relaxed_m)
        e = [(polygon[:, 0] / a) ** 2 + ((polygon[:, 1] - s * c) / b) ** 2 for s in (1, -1)]
        on_ellipse = np.isclose(e[0], 1.0) | np.isclose(e[1], 1.0)
        assert np.all(on_disc | on_ellipse)
        # Counter-clockwise: positive area (shoelace).
        x, y = polygon[:, 0], polygon[:, 1]
        assert 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0.0
    # State II's front half-disc (x_T >= 0) is the relaxed radius, face to face plus l_margin.
    if state == pa.STATE_II:
        front = outlines[1]
        assert np.allclose(np.hypot(*front.T), GEOMETRY.r_relaxed_m)
        assert np.all(front[:, 0] >= -1e-12)


def test_prisms_enclose_the_polygon_times_the_height():
    polygon = keepout_outlines_T(GEOMETRY, pa.STATE_I)[0]
    vertices, faces = prism_mesh(polygon, 0.3)
    M = len(polygon)
    assert vertices.shape == (3, 2 * M) and faces.shape == (3, 4 * M - 4)
    assert faces.min() == 0 and faces.max() == 2 * M - 1
    # Divergence theorem: sum over triangles of v0 . (v1 x v2) / 6, consistently wound.
    v = vertices.T[faces.T]
    volume = np.sum(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2]))) / 6.0
    x, y = polygon[:, 0], polygon[:, 1]
    area = 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
    assert abs(volume) == pytest.approx(area * 0.3, rel=1e-12)


def test_the_zone_follows_the_target_and_switches_with_the_chaser():
    recorder = _RecordingMeshcat()
    system = _simulate(recorder)
    times = [round(t, 9) for t in np.arange(0.0, 10.0 + 1e-9, PERIOD_S)]
    node = recorder.transforms[system.target_path]
    assert sorted(node) == times
    for t, X_LT in node.items():
        np.testing.assert_allclose(
            X_LT.rotation().matrix()[:2, 0], [math.cos(OMEGA * t), math.sin(OMEGA * t)], atol=1e-12
        )
        np.testing.assert_allclose(X_LT.translation(), 0.0, atol=0.0)
    switched = round(math.ceil(SWITCH_S / PERIOD_S) * PERIOD_S, 9)  # the first publish after
    assert recorder.properties[(system.state_path(pa.STATE_I), "visible")] == {
        0.0: True,
        switched: False,
    }
    assert recorder.properties[(system.state_path(pa.STATE_II), "visible")] == {
        0.0: False,
        switched: True,
    }
    # Both zones are drawn under the target node: 3 pieces for State I, 4 for State II.
    for state, count in ((pa.STATE_I, 3), (pa.STATE_II, 4)):
        pieces = [p for p in recorder.meshes if p.startswith(system.state_path(state) + "/")]
        assert len(pieces) == count


def test_a_chaser_turned_off_the_docking_face_stays_in_state_i():
    """State II needs the heading on the face (rpod.models.planar_approach): the same path
    flown 10 deg off it never shows the relaxed zone."""
    recorder = _RecordingMeshcat()
    system = _simulate(recorder, heading_error_rad=math.radians(10.0))
    assert recorder.properties.get((system.state_path(pa.STATE_II), "visible"), {0.0: False}) == {
        0.0: False
    }


def test_a_real_meshcat_holds_every_path():
    meshcat = make_headless_meshcat()
    system = _simulate(meshcat, duration_s=1.0, record=True)
    assert isinstance(system, PlanarKeepOutScene)
    for path in (
        "/drake/rpod/planar_kos/target/state_1/piece_0",
        "/drake/rpod/planar_kos/target/state_1/outline_2",
        "/drake/rpod/planar_kos/target/state_2/piece_3",
        "/drake/rpod/planar_plan/goal",
    ):
        assert meshcat.HasPath(path), path


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="publish_period_s"):
        PlanarKeepOutScene(None, GEOMETRY, 0.0)
    with pytest.raises(ValueError, match="height_m"):
        PlanarKeepOutScene(None, GEOMETRY, 0.1, height_m=-1.0)
    with pytest.raises(ValueError, match="points_per_half"):
        keepout_outlines_T(GEOMETRY, pa.STATE_I, points_per_half=1)
    with pytest.raises(ValueError, match="state"):
        keepout_outlines_T(GEOMETRY, 3)
