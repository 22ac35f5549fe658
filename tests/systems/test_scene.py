"""Tests of rpod.systems.scene and rpod.diagrams.recording, without the rest of rpod.

The four scene inputs come from pydrake sources: a chaser flying a straight line towards the
target over 20 s, a target spinning at 5 deg/s about its z axis, q_IL identity (or a fixed
rotation for the pose test).
"""

from __future__ import annotations

import base64
import re
from pathlib import Path

import numpy as np
import pytest
from pydrake.common.yaml import yaml_load_typed
from pydrake.geometry import SceneGraph
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Multiplexer, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial
from scipy.spatial.transform import Rotation

from rpod.diagrams.recording import (
    make_headless_meshcat,
    save_recording_html,
    screenshot_html,
    start_recording,
)
from rpod.systems.scene import RendezvousScene, SceneConfig, SceneDriver, SceneGeometry
from rpod.systems.sensed import SENSED_FIELDS, sensed_vector

CHROMIUM = Path("/usr/bin/chromium")
DURATION_S = 20.0
SPIN_RATE_RAD_S = np.radians(5.0)
P_START_L = np.array([-4.0, 18.0, 3.0])
P_END_L = np.array([0.0, 3.0, 0.0])


def _wxyz(rotation: Rotation) -> np.ndarray:
    """scipy quaternion (x, y, z, w) to (w, x, y, z)."""
    x, y, z, w = rotation.as_quat()
    return np.array([w, x, y, z])


def _add_sources(builder: DiagramBuilder, q_IL: np.ndarray) -> dict:
    """Adds sources of the sensed bundle; returns {'sensed': its port}."""
    velocity = (P_END_L - P_START_L) / DURATION_S
    relative_state = PiecewisePolynomial.FirstOrderHold(
        [0.0, DURATION_S], np.column_stack([np.r_[P_START_L, velocity], np.r_[P_END_L, velocity]])
    )
    # A quaternion is not linear in time; sample finely, the scene normalises the chord.
    times = np.linspace(0.0, DURATION_S, 81)
    w_IT_T = np.array([0.0, 0.0, SPIN_RATE_RAD_S])
    target_samples = np.column_stack(
        [np.r_[_wxyz(Rotation.from_rotvec(w_IT_T * t)), w_IT_T] for t in times]
    )
    target_attitude = PiecewisePolynomial.FirstOrderHold(times, target_samples)
    q_IC = _wxyz(Rotation.from_euler("z", 200.0, degrees=True))
    sources = {
        "relative_state_L": builder.AddSystem(TrajectorySource(relative_state)),
        "q_IL": builder.AddSystem(ConstantVectorSource(q_IL)),
        "target_attitude": builder.AddSystem(TrajectorySource(target_attitude)),
        "chaser_attitude": builder.AddSystem(ConstantVectorSource(np.r_[q_IC, 0.0, 0.0, 0.0])),
    }
    sources["w_IL_L"] = builder.AddSystem(ConstantVectorSource(np.zeros(3)))
    sources["target_state_I"] = builder.AddSystem(ConstantVectorSource(np.full(6, np.nan)))
    bundle = builder.AddSystem(Multiplexer([size for _, size in SENSED_FIELDS]))
    for index, (name, _) in enumerate(SENSED_FIELDS):
        builder.Connect(sources[name].get_output_port(), bundle.get_input_port(index))
    return {"sensed": bundle.get_output_port()}


def test_config_defaults_and_validation():
    """How to draw (SceneConfig, a scenario's visualization block) apart from what (SceneGeometry,
    from the scenario's bodies and docking geometry)."""
    config, geometry = SceneConfig(), SceneGeometry()
    config.validate()
    geometry.validate()
    assert geometry.target_box_size_m == [2.0, 2.0, 2.0]
    assert geometry.chaser_box_size_m == [1.5, 1.5, 1.5]
    assert config.publish_period_s == 0.5 and config.trail
    loaded = yaml_load_typed(
        schema=SceneConfig, data="{publish_period_s: 0.2, trail: false}", defaults=SceneConfig()
    )
    assert loaded.publish_period_s == 0.2 and not loaded.trail and loaded.trail_max_points == 400
    with pytest.raises(ValueError, match="docking_axis_T"):
        SceneGeometry(docking_axis_T=[0.0, 0.0, 0.0]).validate()
    with pytest.raises(ValueError, match="corridor_half_angle_deg"):
        SceneGeometry(corridor_half_angle_deg=95.0).validate()
    with pytest.raises(ValueError, match="publish_period_s"):
        SceneConfig(publish_period_s=0.0).validate()


def test_poses_in_lvlh_match_independent_rotation():
    """X_LT, X_LC from the pose output equal R_IL^T R_IT etc. computed with scipy (to 1e-12)."""
    R_IL = Rotation.from_euler("zyx", [40.0, -25.0, 70.0], degrees=True)
    R_IT = Rotation.from_euler("xyz", [10.0, 80.0, -30.0], degrees=True)
    R_IC = Rotation.from_euler("zxz", [120.0, 45.0, 5.0], degrees=True)
    p_LC_L = np.array([1.0, -12.0, 0.5])
    scene_graph = SceneGraph()
    scene = RendezvousScene(scene_graph, make_headless_meshcat(), SceneConfig())
    assert scene.num_input_ports() == 1 and scene.get_input_port(0).get_name() == "sensed"
    assert scene.get_input_port(0).size() == 33  # the sensed bundle, rpod.systems.sensed
    context = scene.CreateDefaultContext()
    # Non-unit quaternions (scaled by 2) as a drifting integrator would give.
    scene.GetInputPort("sensed").FixValue(
        context,
        sensed_vector(np.r_[p_LC_L, 0.1, 0.2, 0.3], 2.0 * _wxyz(R_IL), np.zeros(3),
                      np.r_[2.0 * _wxyz(R_IT), 0, 0, 1], np.r_[_wxyz(R_IC), 0, 0, 0]),
    )  # fmt: skip

    poses = scene.get_geometry_pose_output_port().Eval(context)
    assert poses.size() == 2
    X_LT = poses.value(scene.target_frame_id())
    X_LC = poses.value(scene.chaser_frame_id())
    np.testing.assert_allclose(
        X_LT.rotation().matrix(), (R_IL.inv() * R_IT).as_matrix(), atol=1e-12
    )
    np.testing.assert_allclose(X_LT.translation(), np.zeros(3), atol=0.0)
    np.testing.assert_allclose(
        X_LC.rotation().matrix(), (R_IL.inv() * R_IC).as_matrix(), atol=1e-12
    )
    np.testing.assert_allclose(X_LC.translation(), p_LC_L, atol=0.0)


class _FakeMeshcat:
    """Records the timed SetTransform/SetProperty calls the scene makes; ignores the rest."""

    def __init__(self):
        self.transforms = {}  # path -> list of (time, position)
        self.visible = {}  # path -> list of (time, bool)

    def SetTransform(self, path, X, time_in_recording=None):
        if time_in_recording is not None:
            self.transforms.setdefault(path, []).append((time_in_recording, X.translation()))

    def SetProperty(self, path, name, value, time_in_recording=None):
        if name == "visible" and time_in_recording is not None:
            self.visible.setdefault(path, []).append((time_in_recording, value))

    def __getattr__(self, name):
        return lambda *args, **kwargs: None

    @staticmethod
    def _keys(track):
        """Key frames sorted by time, a later call at an equal time overwriting (as Meshcat)."""
        keys = {}
        for time, value in track:
            keys[round(time, 9)] = value
        return sorted(keys.items())

    def replay(self, path, t):
        """(visible, position) of `path` at time t, as a linear-interpolating player shows it."""
        visible_keys = self._keys(self.visible[path])
        visible = [value for time, value in visible_keys if time <= t + 1e-9][-1]
        keys = self._keys(self.transforms.get(path, []))
        if not keys:
            return visible, None
        times = np.array([time for time, _ in keys])
        positions = np.array([p for _, p in keys])
        return visible, np.array([np.interp(t, times, positions[:, i]) for i in range(3)])


def test_trail_ring_buffer_replays_without_sliding_markers():
    """With a 6-marker pool over 41 publishes, the replay shows exactly the newest markers.

    Checked at every publish time and half way between: the visible markers sit at the chaser
    positions of the latest marker times (to 1e-12 m), so no reused marker is seen moving.
    """
    pool, period = 6, 0.5
    config = SceneConfig(trail_max_points=pool, publish_period_s=period)
    builder = DiagramBuilder()
    ports = _add_sources(builder, np.array([1.0, 0.0, 0.0, 0.0]))
    scene_graph = builder.AddSystem(SceneGraph())
    meshcat = _FakeMeshcat()
    scene = builder.AddSystem(RendezvousScene(scene_graph, meshcat, config))
    for name, port in ports.items():
        builder.Connect(port, scene.GetInputPort(name))
    builder.Connect(
        scene.get_geometry_pose_output_port(), scene_graph.get_source_pose_port(scene.source_id())
    )
    diagram = builder.Build()
    simulator = Simulator(diagram)
    SceneDriver.for_systems(diagram.GetSystems()).attach(simulator)
    # The scene is drawn at step ends (SceneDriver); this diagram has no events of its own,
    # so the test ends a step at every publish time.
    simulator.Initialize()
    for t in np.arange(0.5, DURATION_S + 1e-9, 0.5):
        simulator.AdvanceTo(t)

    trail_paths = sorted(path for path in meshcat.visible if "/trail/" in path)
    assert len(trail_paths) == pool
    marker_times = np.arange(0.0, DURATION_S + 1e-9, period)
    assert len(meshcat.transforms["rpod/overlay/target_frame"]) == len(marker_times)

    def p_LC_L(t):
        return P_START_L + (P_END_L - P_START_L) * t / DURATION_S

    # Marker m (placed at marker_times[m]) is hidden when its slot is about to be reused, i.e.
    # from the time of marker m + pool - 1 on, provided marker m + pool exists.
    count = len(marker_times)
    for t in np.arange(0.0, DURATION_S + 1e-9, period / 2):
        shown = [meshcat.replay(path, t) for path in trail_paths]
        shown = np.array(sorted((tuple(p) for visible, p in shown if visible)))
        expected = np.array(
            sorted(
                tuple(p_LC_L(marker_times[m]))
                for m in range(count)
                if marker_times[m] <= t and (m + pool >= count or marker_times[m + pool - 1] > t)
            )
        )
        assert shown.shape == expected.shape, f"t={t}"
        np.testing.assert_allclose(shown, expected, atol=1e-12, err_msg=f"t={t}")


def _decoded_commands(html: str) -> list[bytes]:
    """The msgpack Meshcat commands a static HTML file embeds as base64 data URLs."""
    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html)
    return [base64.b64decode(blob) for blob in blobs]


def _pixel_counts_by_colour(png: Path) -> dict[str, int]:
    """Pixels of the target (gold), chaser (blue) and corridor (green) colours in a screenshot.

    Meshcat's background and grid are grey or white, so an empty scene has (almost) none.
    """
    import matplotlib.image

    rgb = matplotlib.image.imread(png)[..., :3].astype(float)
    if rgb.max() > 1.0:
        rgb = rgb / 255.0
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return {
        "target": int(np.count_nonzero(r - b > 0.25)),
        "chaser": int(np.count_nonzero(b - r > 0.25)),
        "corridor": int(np.count_nonzero((g - r > 0.1) & (g - b > 0.05))),
    }


def test_recording_html_replays_scene_and_renders(tmp_path):
    """20 s with recording: the HTML holds the animation, and Chromium draws the bodies."""
    geometry = SceneGeometry(docking_port_T=[1.0, 0.0, 0.0], docking_axis_T=[1.0, 0.0, 0.0])
    meshcat = make_headless_meshcat()
    builder = DiagramBuilder()
    ports = _add_sources(builder, np.array([1.0, 0.0, 0.0, 0.0]))
    RendezvousScene.AddToBuilder(builder, meshcat, SceneConfig(), **ports, geometry=geometry)
    diagram = builder.Build()
    for name in ("scene", "scene.scene_graph", "scene.meshcat_visualizer"):
        assert diagram.HasSubsystemNamed(name), name
    simulator = Simulator(diagram)
    SceneDriver.for_systems(diagram.GetSystems()).attach(simulator)
    start_recording(meshcat, fps=32.0)
    # The scene is drawn at step ends (SceneDriver); this diagram has no events of its own,
    # so the test ends a step at every publish time.
    simulator.Initialize()
    for t in np.arange(0.5, DURATION_S + 1e-9, 0.5):
        simulator.AdvanceTo(t)
    html_path = save_recording_html(meshcat, tmp_path / "out" / "recording.html")

    assert html_path.is_file()
    assert not list(html_path.parent.glob(".*.tmp")), "temporary file left behind"
    html = html_path.read_text(encoding="utf-8")
    commands = _decoded_commands(html)
    animations = [command for command in commands if b"set_animation" in command]
    assert len(animations) == 1, "the recording is not in the HTML"
    animation = animations[0]
    for animated_path in (
        b"/drake/rpod/bodies/target",
        b"/drake/rpod/bodies/chaser",
        b"/drake/rpod/overlay/target_frame",
        b"/drake/rpod/overlay/trail/00000",
        b"/drake/rpod/overlay/trail/00040",
    ):
        assert animated_path in animation, animated_path
    assert any(
        b"set_object" in c and b"rpod/overlay/target_frame/corridor/cone" in c for c in commands
    )

    if not CHROMIUM.exists():
        print(f"{CHROMIUM} is absent: skipping the rendering check")
        pytest.skip(f"{CHROMIUM} is absent")
    png_path = tmp_path / "recording.png"
    assert screenshot_html(html_path, png_path, timeout_s=60.0, chromium=str(CHROMIUM), attempts=2)
    counts = _pixel_counts_by_colour(png_path)
    # From the default camera (800 x 600) the 2 m target box covers ~1300 gold pixels, the 1.5 m
    # chaser box ~350 blue ones at its farthest, the corridor tens of thousands; an empty scene
    # has fewer than 20 of each. The thresholds leave a wide margin for shading differences.
    assert counts["target"] > 500, f"{counts} in {png_path}"
    assert counts["chaser"] > 100, f"{counts} in {png_path}"
    assert counts["corridor"] > 5000, f"{counts} in {png_path}"
