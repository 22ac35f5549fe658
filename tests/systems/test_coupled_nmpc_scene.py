"""Paper 001's coupled NMPC in the Meshcat scene (rpod.systems.coupled_nmpc_scene).

Truths: the drawn pyramid is eq. 18's set { A_p (p - p_TPt_T) <= 0 } cut at its length, with
A_p from rpod.models.coupled_relative.los_polyhedron: the apex on all four planes, each corner
on exactly two and inside the other two, the edges at atan(sqrt(2) tan(alpha)) off the axis,
and the registered hull's volume that of a square pyramid with half-side L tan(alpha), by hand.
The arrows against hand-computed thrusters of gimbaled_cuboid_8; in a diagram, the chaser node
follows X_LC = (R_IL^T R_IC, p_LC_L) computed here with scipy, each arrow sits at p_CK_C along
-f_k with length 0.1 m/N |f_k|, and a thruster that turns on is shown from that publish on; a
real Meshcat and a recording hold every path.
"""

import base64
import math
import re

import numpy as np
import pytest
from pydrake.geometry import Convex, Sphere
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from rpod.diagrams.recording import make_headless_meshcat, save_recording_html, start_recording
from rpod.models.coupled_relative import (
    CHASER_FEATURE_POINT_C_M,
    TARGET_FEATURE_POINT_T_M,
    los_polyhedron,
)
from rpod.models.thrusters import gimbaled_cuboid_8
from rpod.systems.coupled_nmpc_scene import (
    ThrustArrows,
    add_coupled_scene,
    los_pyramid_vertices,
    thrust_arrows_C,
)
from rpod.systems.scene import RendezvousScene, SceneConfig, SceneDriver
from rpod.systems.sensed import sensed_vector

LAYOUT = gimbaled_cuboid_8()
PERIOD_S = 0.25
P_LC_L = np.array([3.0, 15.0, -2.0])
R_IL = Rotation.from_euler("zyx", [40.0, -25.0, 70.0], degrees=True)
R_IT = Rotation.from_euler("xyz", [10.0, 80.0, -30.0], degrees=True)
R_IC = Rotation.from_euler("zxz", [-35.0, 120.0, 15.0], degrees=True)


def _wxyz(rotation: Rotation) -> np.ndarray:
    x, y, z, w = rotation.as_quat()
    return np.array([w, x, y, z])


@pytest.mark.parametrize(
    "p_TPt_T, half_angle_rad",
    [(TARGET_FEATURE_POINT_T_M, math.pi / 4), (np.array([-4.0, 0.5, -2.0]), math.radians(20.0))],
)
def test_pyramid_vertices_lie_on_the_planes_of_los_polyhedron(p_TPt_T, half_angle_rad):
    length = 20.0
    vertices = los_pyramid_vertices(p_TPt_T, half_angle_rad, length)
    assert vertices.shape == (5, 3)
    A_p = los_polyhedron(p_TPt_T, half_angle_rad)  # eq. 18: A_p p_PtPc_T <= 0
    g = (vertices - p_TPt_T) @ A_p.T
    np.testing.assert_allclose(g[0], 0.0, atol=0.0)  # the apex is the rock
    on = np.abs(g[1:]) <= 1e-9 * length
    assert np.all(on.sum(axis=1) == 2), g  # a corner: two faces meet there
    assert np.all(g[1:][~on] < -1.0)  # and it is well inside the other two
    axis = p_TPt_T / np.linalg.norm(p_TPt_T)
    edges = vertices[1:] - p_TPt_T
    np.testing.assert_allclose(edges @ axis, length, rtol=1e-12)
    opening = np.arccos(edges @ axis / np.linalg.norm(edges, axis=1))
    corner = math.atan(math.sqrt(2.0) * math.tan(half_angle_rad))  # 54.74 deg for pi/4
    np.testing.assert_allclose(opening, corner, atol=1e-12)
    # Four distinct corners, each pair of neighbours sharing one face (ordered about the axis).
    shared = [np.flatnonzero(on[k] & on[(k + 1) % 4]) for k in range(4)]
    assert [len(s) for s in shared] == [1, 1, 1, 1]


def test_a_non_positive_length_is_refused():
    with pytest.raises(ValueError, match="length_m"):
        los_pyramid_vertices(TARGET_FEATURE_POINT_T_M, math.pi / 4, 0.0)


def test_thrust_arrows_hand_cases():
    n = LAYOUT.directions_C
    F = np.zeros((8, 3))
    F[0] = 20.0 * n[0]  # nominal, full thrust: the plume leaves along p_CK/|p_CK|
    F[1] = np.array([0.0, -6.0, 8.0])  # 10 N in some direction
    F[3] = 0.5e-3 * n[3]  # below the 1 mN default: hidden
    origins, directions, lengths = thrust_arrows_C(LAYOUT, F.reshape(-1), 0.1)
    np.testing.assert_array_equal(origins, LAYOUT.p_CK_C)
    p0 = LAYOUT.p_CK_C[0]
    np.testing.assert_allclose(directions[0], p0 / np.linalg.norm(p0), atol=1e-15)
    np.testing.assert_allclose(directions[1], [0.0, 0.6, -0.8], atol=1e-15)
    np.testing.assert_allclose(lengths, [2.0, 1.0, 0, 0, 0, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(directions[2:], -n[2:], atol=0.0)  # off: the nominal plume
    _, along_force, _ = thrust_arrows_C(LAYOUT, F, 0.1, exhaust=False)
    np.testing.assert_allclose(along_force[1], [0.0, -0.6, 0.8], atol=1e-15)
    np.testing.assert_allclose(along_force[2], n[2], atol=0.0)


class _RecordingMeshcat:
    """Records the timed SetTransform / SetProperty calls; ignores the rest."""

    def __init__(self):
        self.transforms = {}  # path -> {time: RigidTransform}
        self.properties = {}  # (path, property) -> {time: value}

    def SetTransform(self, path, X, time_in_recording=None):
        if time_in_recording is not None:
            self.transforms.setdefault(path, {})[round(time_in_recording, 9)] = X

    def SetProperty(self, path, name, value, time_in_recording=None):
        if time_in_recording is not None:
            self.properties.setdefault((path, name), {})[round(time_in_recording, 9)] = value

    def __getattr__(self, name):
        return lambda *args, **kwargs: None


def _scene_diagram(
    meshcat, forces_source, arrows_meshcat=None, duration_s=1.0, record=False, clip=False
):
    """The scene fed a constant sensed bundle, plus the coupled extras; simulated."""
    builder = DiagramBuilder()
    sensed = sensed_vector(
        np.r_[P_LC_L, 0.0, 0.0, 0.0],
        _wxyz(R_IL),
        np.zeros(3),
        np.r_[_wxyz(R_IT), 0.0, 0.0, 0.0],
        np.r_[_wxyz(R_IC), 0.0, 0.0, 0.0],
    )
    source = builder.AddSystem(ConstantVectorSource(sensed))
    config = SceneConfig(publish_period_s=PERIOD_S, trail=False)
    scene = RendezvousScene.AddToBuilder(builder, meshcat, config, source.get_output_port())
    forces = builder.AddSystem(forces_source)
    if arrows_meshcat is None:
        arrows = add_coupled_scene(
            builder,
            meshcat,
            scene,
            LAYOUT,
            TARGET_FEATURE_POINT_T_M,
            CHASER_FEATURE_POINT_C_M,
            math.pi / 4,
            forces.get_output_port(),
            publish_period_s=PERIOD_S,
        )
    else:  # the arrows alone, drawing in a recorder
        arrows = builder.AddSystem(
            ThrustArrows(
                arrows_meshcat,
                LAYOUT,
                scene.chaser_frame_id(),
                CHASER_FEATURE_POINT_C_M,
                PERIOD_S,
                clip=clip,
            )
        )
        builder.Connect(forces.get_output_port(), arrows.get_thruster_forces_input_port())
        builder.Connect(
            scene.get_geometry_pose_output_port(), arrows.get_geometry_pose_input_port()
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
    return diagram, scene, arrows


def test_arrows_follow_the_chaser_and_the_forces():
    # Thruster 0 at full nominal thrust throughout; thruster 5 off, then 5 N from t = 0.5 s on.
    n = LAYOUT.directions_C
    off, on = np.zeros((8, 3)), np.zeros((8, 3))
    off[0] = on[0] = 20.0 * n[0]
    on[5] = np.array([1.0, 2.0, 2.0]) * 5.0 / 3.0
    forces = PiecewisePolynomial.ZeroOrderHold(
        [0.0, 0.5, 10.0], np.column_stack([off.reshape(-1), on.reshape(-1), on.reshape(-1)])
    )
    recorder = _RecordingMeshcat()
    _scene_diagram(make_headless_meshcat(), TrajectorySource(forces), recorder)
    times = [round(t, 9) for t in np.arange(0.0, 1.0 + 1e-9, PERIOD_S)]
    chaser = recorder.transforms["rpod/coupled_nmpc/chaser"]
    assert sorted(chaser) == times
    R_LC = (R_IL.inv() * R_IC).as_matrix()
    for X_LC in chaser.values():
        np.testing.assert_allclose(X_LC.rotation().matrix(), R_LC, atol=1e-12)
        np.testing.assert_allclose(X_LC.translation(), P_LC_L, atol=0.0)

    def arrow(k, t):
        X = recorder.transforms[f"rpod/coupled_nmpc/chaser/thrusters/{k}"][t]
        shaft = recorder.properties[(f"rpod/coupled_nmpc/chaser/thrusters/{k}/shaft", "scale")][t]
        tip = recorder.transforms[f"rpod/coupled_nmpc/chaser/thrusters/{k}/head"][t]
        return X, shaft[2] + 0.15, tip.translation()[2]  # the 0.15 m head on the shaft

    for t in times:
        X, length, tip = arrow(0, t)
        np.testing.assert_allclose(X.translation(), LAYOUT.p_CK_C[0], atol=0.0)
        np.testing.assert_allclose(X.rotation().matrix()[:, 2], -n[0], atol=1e-12)
        assert length == pytest.approx(2.0, abs=1e-12) and tip == pytest.approx(2.0, abs=1e-12)
    visible = recorder.properties[("rpod/coupled_nmpc/chaser/thrusters/5", "visible")]
    assert visible == {0.0: False, 0.5: True}
    for t in (0.5, 0.75, 1.0):
        X, length, tip = arrow(5, t)
        np.testing.assert_allclose(X.rotation().matrix()[:, 2], -on[5] / 5.0, atol=1e-12)
        assert length == pytest.approx(0.5, abs=1e-12) and tip == pytest.approx(0.5, abs=1e-12)
    assert 0.25 not in recorder.transforms["rpod/coupled_nmpc/chaser/thrusters/5"]
    never = recorder.properties[("rpod/coupled_nmpc/chaser/thrusters/7", "visible")]
    assert never == {0.0: False}


def test_commands_are_drawn_as_the_bank_clips_them():
    n = LAYOUT.directions_C
    command = np.zeros((8, 3))
    command[0] = 30.0 * n[0]  # beyond f_max = 20 N (eq. 17): drawn 2 m long, not 3 m
    command[1] = -5.0 * n[1]  # against the pyramid (eq. 16): clipped to zero, hidden
    recorder = _RecordingMeshcat()
    source = ConstantVectorSource(command.reshape(-1))
    _scene_diagram(make_headless_meshcat(), source, recorder, duration_s=0.0, clip=True)
    root = "rpod/coupled_nmpc/chaser/thrusters"
    assert recorder.properties[(f"{root}/0/shaft", "scale")][0.0][2] == pytest.approx(1.85)
    assert recorder.transforms[f"{root}/0/head"][0.0].translation()[2] == pytest.approx(2.0)
    assert recorder.properties[(f"{root}/1", "visible")] == {0.0: False}
    # Unclipped, the same command is drawn as given: 3 m, and thruster 1's plume along +n.
    recorder = _RecordingMeshcat()
    source = ConstantVectorSource(command.reshape(-1))  # a system is built into one diagram
    _scene_diagram(make_headless_meshcat(), source, recorder, duration_s=0.0)
    assert recorder.transforms[f"{root}/0/head"][0.0].translation()[2] == pytest.approx(3.0)
    assert recorder.properties[(f"{root}/1", "visible")] == {0.0: True}


def _decoded_commands(html: str) -> list[bytes]:
    """The msgpack Meshcat commands a static HTML file embeds as base64 data URLs."""
    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html)
    return [base64.b64decode(blob) for blob in blobs]


def test_scene_builds_publishes_and_records(tmp_path):
    meshcat = make_headless_meshcat()
    forces = np.zeros((8, 3))
    forces[2] = 12.0 * LAYOUT.directions_C[2]
    diagram, scene, arrows = _scene_diagram(
        meshcat, ConstantVectorSource(forces.reshape(-1)), record=True
    )
    assert isinstance(arrows, ThrustArrows)
    assert diagram.GetSubsystemByName("coupled_nmpc_scene") is arrows
    for path in (
        "/drake/rpod/bodies/target/coupled_los",
        "/drake/rpod/bodies/target/coupled_rock",
        "/drake/rpod/coupled_nmpc/chaser/end_effector",
        "/drake/rpod/coupled_nmpc/chaser/thrusters/2/shaft/cylinder",
        "/drake/rpod/coupled_nmpc/chaser/thrusters/2/head/size/cone",
    ):
        assert meshcat.HasPath(path), path
    # The pyramid, its edges and the rock are on the target frame; the hull is the cut pyramid.
    scene_graph = diagram.GetSubsystemByName("scene.scene_graph")
    inspector = scene_graph.model_inspector()
    names = {
        inspector.GetName(g): g
        for g in inspector.GetAllGeometryIds()
        if inspector.GetFrameId(g) == scene.target_frame_id()
    }
    assert {"coupled_los", "coupled_rock"} | {f"coupled_los_edge_{k}" for k in range(4)} <= set(
        names
    )
    shape = inspector.GetShape(names["coupled_los"])
    assert isinstance(shape, Convex)
    hull = shape.GetConvexHull()
    drawn = np.array([hull.vertex(i) for i in range(hull.num_vertices())])
    # A square pyramid of height L and half-side L tan(pi/4): volume (2 L)^2 L / 3.
    assert ConvexHull(drawn).volume == pytest.approx(4.0 * 20.0**3 / 3.0, rel=1e-9)
    rock = inspector.GetShape(names["coupled_rock"])
    assert isinstance(rock, Sphere)
    np.testing.assert_array_equal(
        inspector.GetPoseInFrame(names["coupled_rock"]).translation(), TARGET_FEATURE_POINT_T_M
    )
    html = save_recording_html(meshcat, tmp_path / "recording.html").read_text(encoding="utf-8")
    animation = [c for c in _decoded_commands(html) if b"set_animation" in c]
    assert len(animation) == 1
    for path in (
        b"/drake/rpod/coupled_nmpc/chaser",
        b"/drake/rpod/coupled_nmpc/chaser/thrusters/2/shaft",
        b"/drake/rpod/coupled_nmpc/chaser/thrusters/2/head",
    ):
        assert path in animation[0], path


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="p_CPc_C"):
        ThrustArrows(None, LAYOUT, None, [0.0, 1.0], PERIOD_S)
    with pytest.raises(ValueError, match="publish_period_s"):
        ThrustArrows(None, LAYOUT, None, CHASER_FEATURE_POINT_C_M, 0.0)
