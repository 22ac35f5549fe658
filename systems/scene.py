"""Scene geometry of a rendezvous for Meshcat: bodies, docking corridor, LVLH triad, chaser trail.

This module owns what the user sees in Meshcat and in the standalone HTML recording. It does not
own the Meshcat instance, the recording (see `rpod.diagrams.recording`), or any dynamics.

The Meshcat world frame is the target's LVLH frame L (origin at the target's centre of mass, x
radial out, y along-track, z orbit normal). From the four inputs the system forms

    R_LT = R_IL^T R_IT,   R_LC = R_IL^T R_IC,   X_LT = (R_LT, 0),   X_LC = (R_LC, p_LC_L).

Two drawing paths are used (the split is deliberate):

- Bodies (option a). The target box and the chaser box, each with a small body-axes triad, are
  registered with a SceneGraph (one source, frames "target" and "chaser", illustration role).
  A body given by polytope vertices (`target_vertices_T`, `chaser_vertices_C`, e.g. paper 000's
  soft-capture hulls) is registered instead as a `Convex` shape made from an in-memory OBJ of
  its convex hull (faces from scipy's Qhull, wound outward), which Meshcat draws as that hull.
  `RendezvousScene` outputs their poses as a FramePoseVector and a `MeshcatVisualizer` draws them
  under `/drake/<prefix>/bodies`. Its transforms carry the simulation time, so they are recorded.
  `RegisterTargetGeometry` adds more shapes fixed in T the same way (paper 004's LOS corridor,
  rpod.systems.los_corridor_scene).
- Overlays (option b), drawn directly with Meshcat under `/drake/<prefix>/overlay` from this
  system's initialization event and its `PublishScene`, which the diagram's `SceneDriver`
  calls from the Simulator's monitor (never a periodic event: see SceneDriver):
  * `lvlh_triad`: three cylinders at the origin, x red, y green, z blue (static).
  * `target_frame`: a node whose transform is X_LT (recorded at every publish). Under it, fixed in
    T: the docking port (small sphere), the docking axis (a thin cylinder along d_T; WebGL draws
    SetLine one pixel wide, which is hard to see), and the approach corridor, a translucent
    MeshcatCone with apex at the port, axis d_T, half angle and length from the config, plus a
    wireframe outline (8 generators and the rim). The corridor therefore rotates with the target.
  * `trail`: a fixed pool of `trail_max_points` small spheres created at initialization and hidden
    (recorded `visible=False` at the start time). Every `trail_stride`-th publish moves the next
    sphere of the pool to p_LC_L and shows it, both recorded at that time. When the pool is used
    up, the oldest sphere is reused (ring buffer): it is hidden and pinned at its old place at the
    previous marker time, then moved and shown at the new time, so a replay never shows a marker
    sliding across the scene. The trail therefore shows the last
    `trail_max_points * trail_stride * publish_period_s` seconds (200 s with the defaults) and it
    grows in the replay exactly as it did in the simulation.

`PlannedPathOverlay` (a second, optional system) draws a planner's paths under
`/drake/<prefix>/overlay/plans`: each new plan (a `planned_path` input whose `index` changed)
becomes a line through its knots plus a point cloud of the knots, hidden in the recording until
the plan's time and hidden again when the next plan replaces it.

Why the pool: a Meshcat recording animates only transforms and properties of objects that exist
in the final scene tree; it cannot replay object creation. Pre-allocated, toggled markers make
the trail a true animation at a bounded scene size.

Cost: everything happens in publishes at `publish_period_s` (default 0.5 s of simulated
time): one transform for the target node and at most four calls for the trail per publish; the
pose output is only evaluated by the visualizer's publish. Nothing runs per integrator step.

The trail bookkeeping (last marker positions, a counter) lives in Python members, reset by the
initialization event, the way MeshcatVisualizer keeps its own bookkeeping: one scene serves one
simulation (context) at a time. For a recording, call `Meshcat.StartRecording` before
`Simulator.Initialize` so the initial hidden state of the trail is recorded.
"""

# No `from __future__ import annotations` here: yaml_load_typed reads SceneConfig's field types
# at run time and fails on string annotations such as 'list[float]'.
import math
from dataclasses import dataclass, field

import numpy as np
from pydrake.common import MemoryFile
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    Box,
    Convex,
    Cylinder,
    FramePoseVector,
    GeometryFrame,
    GeometryId,
    GeometryInstance,
    InMemoryMesh,
    MakePhongIllustrationProperties,
    Meshcat,
    MeshcatCone,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Rgba,
    SceneGraph,
    Sphere,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.perception import BaseField, Fields, PointCloud
from pydrake.systems.framework import DiagramBuilder, EventStatus, OutputPort

from rpod.models.config import ConfigError
from rpod.models.frames import rotation_from_wxyz
from rpod.systems.lifetime import LeafSystem
from rpod.systems.sensed import SENSED_PORT, Sensed, declare_sensed_input

CAMERA_FOV_DEG = 60.0  # vertical field of view of the recording's camera
NOMINAL_VIEW_PIXELS = 600  # height of the browser view the locators are sized for
LOCATOR_PIXELS = 10  # a body smaller than this on screen gets a locator this size
LOCATOR_ALPHA = 0.35

# Colours (r, g, b, a). Axis colours follow the usual x red, y green, z blue.
TARGET_RGBA = Rgba(0.85, 0.65, 0.20, 1.0)
CHASER_RGBA = Rgba(0.20, 0.45, 0.85, 1.0)
TRAIL_RGBA = Rgba(0.30, 0.65, 1.00, 1.0)
DOCKING_AXIS_RGBA = Rgba(1.00, 0.45, 0.00, 1.0)
CORRIDOR_RGBA = Rgba(0.20, 0.80, 0.40, 0.18)
CORRIDOR_EDGE_RGBA = Rgba(0.10, 0.55, 0.25, 1.0)
AXIS_RGBA = (Rgba(0.9, 0.1, 0.1, 1.0), Rgba(0.1, 0.75, 0.1, 1.0), Rgba(0.1, 0.2, 0.9, 1.0))
PLAN_RGBA = Rgba(0.85, 0.10, 0.60, 1.0)


@dataclass
class SceneConfig:
    """How the Meshcat scene is drawn and updated (a scenario's `visualization` block).

    The geometry it draws (bodies, docking port and axis, corridor) is the scenario's own and
    comes in a `SceneGeometry`. Loadable with `pydrake.common.yaml.yaml_load_typed`;
    `validate()` names a bad field.
    """

    # Period of scene updates (and of the MeshcatVisualizer) in simulated time [s].
    publish_period_s: float = 0.5
    # Draw the chaser's trail (past positions).
    trail: bool = True
    # Size of the trail's marker pool; older markers are reused (ring buffer).
    trail_max_points: int = 400
    # Place a trail marker every `trail_stride` publishes (longer history, sparser trail).
    trail_stride: int = 1
    # Radius of a trail marker [m].
    trail_marker_radius_m: float = 0.1
    # Length of the LVLH axes triad at the origin [m]; the body triads are scaled to the boxes.
    lvlh_axis_length_m: float = 3.0
    # Meshcat camera position in L [m], looking at the centre of what the run drew; empty (the
    # default) frames the run: the camera looks at that centre from camera_direction_L, far
    # enough to show the target and the chaser's whole path (RendezvousScene.FrameCamera).
    camera_position_L_m: list[float] = field(default_factory=list)
    # Direction from the content's centre to the camera, in L, when the camera frames the run.
    camera_direction_L: list[float] = field(default_factory=lambda: [0.45, -0.75, 0.5])
    # Keep Meshcat's grey gradient background. It is drawn as a finite box, whose faces cut
    # through the view once the camera is some 30 m out; off gives a plain white background.
    meshcat_background: bool = False

    def validate(self) -> None:
        """Raises ConfigError naming the first bad field."""
        for name in ("publish_period_s", "trail_marker_radius_m", "lvlh_axis_length_m"):
            if not np.isfinite(getattr(self, name)) or getattr(self, name) <= 0.0:
                raise ConfigError(name, f"must be positive, got {getattr(self, name)}")
        if self.trail_max_points < 1 or self.trail_stride < 1:
            raise ConfigError("trail_max_points", "trail_max_points and trail_stride must be >= 1")
        if len(self.camera_position_L_m) not in (0, 3) or not np.all(
            np.isfinite(np.asarray(self.camera_position_L_m, dtype=float))
        ):
            raise ConfigError("camera_position_L_m", "must be empty or 3 finite numbers")
        direction = np.asarray(self.camera_direction_L, dtype=float)
        if direction.shape != (3,) or not np.all(np.isfinite(direction)):
            raise ConfigError("camera_direction_L", "must be 3 finite numbers")
        if np.linalg.norm(direction) < 1e-9:
            raise ConfigError("camera_direction_L", "must not be zero")


@dataclass
class SceneGeometry:
    """What the scene draws: the bodies, the docking port and axis, the approach corridor.

    Built from the scenario (rpod.diagrams), not written by a user; `validate()` names a bad
    field.
    """

    # Target box edge lengths along the T axes (x, y, z) [m].
    target_box_size_m: list[float] = field(default_factory=lambda: [2.0, 2.0, 2.0])
    # Chaser box edge lengths along the C axes (x, y, z) [m].
    chaser_box_size_m: list[float] = field(default_factory=lambda: [1.5, 1.5, 1.5])
    # Docking port: a point of the target, from the target CoM, expressed in T [m].
    docking_port_T: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.0])
    # Docking axis direction in T (normalised here); the corridor opens along it.
    docking_axis_T: list[float] = field(default_factory=lambda: [0.0, 0.0, 1.0])
    # Approach-corridor cone half angle about the docking axis [deg].
    corridor_half_angle_deg: float = 30.0
    # Approach-corridor length from the docking port along the axis [m].
    corridor_length_m: float = 20.0
    # Target polytope vertices (V, 3) in T [m]; when given, the target is drawn as their convex
    # hull instead of the box (target_box_size_m is then unused).
    target_vertices_T: list[list[float]] = field(default_factory=list)
    # Chaser polytope vertices (V, 3) in C [m]; when given, drawn as their convex hull.
    chaser_vertices_C: list[list[float]] = field(default_factory=list)

    def validate(self) -> None:
        """Raises ConfigError (a ValueError) naming the first bad field."""

        def _vector(name: str, positive: bool = False, nonzero: bool = False) -> None:
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise ConfigError(name, f"must be 3 finite numbers, got {value}")
            if positive and np.any(value <= 0.0):
                raise ConfigError(name, f"must be positive, got {value}")
            if nonzero and np.linalg.norm(value) < 1e-9:
                raise ConfigError(name, "must be a nonzero vector")

        _vector("target_box_size_m", positive=True)
        _vector("chaser_box_size_m", positive=True)
        _vector("docking_port_T")
        _vector("docking_axis_T", nonzero=True)
        if not 0.0 < self.corridor_half_angle_deg < 90.0:
            raise ConfigError("corridor_half_angle_deg", "must be in (0, 90)")
        if not np.isfinite(self.corridor_length_m) or self.corridor_length_m <= 0.0:
            raise ConfigError("corridor_length_m", "must be positive")
        for name in ("target_vertices_T", "chaser_vertices_C"):
            vertices = np.asarray(getattr(self, name), dtype=float)
            if vertices.size and (
                vertices.ndim != 2
                or vertices.shape[1] != 3
                or len(vertices) < 4
                or not np.all(np.isfinite(vertices))
            ):
                raise ConfigError(name, "must be empty or >= 4 finite 3-D points")

    def body_extent_m(self, body: str) -> float:
        """The largest edge of the body's bounding box ('target' or 'chaser') [m]."""
        vertices = self.target_vertices_T if body == "target" else self.chaser_vertices_C
        if len(vertices):
            v = np.asarray(vertices, dtype=float)
            return float(np.max(v.max(axis=0) - v.min(axis=0)))
        return float(max(self.target_box_size_m if body == "target" else self.chaser_box_size_m))


def convex_hull_obj(vertices: np.ndarray) -> str:
    """Wavefront OBJ text of the convex hull of points (V, 3): vertices and outward triangles."""
    points = np.asarray(vertices, dtype=float)
    from scipy.spatial import ConvexHull  # at use: every rpod process starts ~0.25 s sooner

    hull = ConvexHull(points)
    centre = points[hull.vertices].mean(axis=0)
    lines = [f"v {x:.12g} {y:.12g} {z:.12g}" for x, y, z in points]
    for simplex in hull.simplices:
        a, b, c = points[simplex]
        if np.cross(b - a, c - a) @ (a - centre) < 0.0:  # wind counter-clockwise from outside
            simplex = simplex[[0, 2, 1]]
        lines.append("f " + " ".join(str(i + 1) for i in simplex))
    return "\n".join(lines) + "\n"


def body_shape(name: str, box_size_m, vertices):
    """A Box, or a Convex hull of the vertices when there are any."""
    if len(vertices):
        obj = convex_hull_obj(np.asarray(vertices, dtype=float))
        return Convex(InMemoryMesh(mesh_file=MemoryFile(obj, ".obj", f"{name}_hull.obj")))
    return Box(*box_size_m)


def _axis_cylinder_pose(axis: int, length: float) -> RigidTransform:
    """Pose of a cylinder (long axis z) lying along `axis` from the origin to `length`."""
    R = [
        RotationMatrix.MakeYRotation(np.pi / 2),
        RotationMatrix.MakeXRotation(-np.pi / 2),
        RotationMatrix(),
    ][axis]
    p = np.zeros(3)
    p[axis] = length / 2.0
    return RigidTransform(R, p)


class RendezvousScene(LeafSystem):
    """Poses of the target and chaser bodies in L, plus Meshcat overlays (corridor, trail, LVLH).

    Input port:
        sensed (33): the sensed bundle (rpod.systems.sensed); the scene draws p_LC_L, q_IL,
            q_IT and q_IC.
    Output port:
        geometry_pose: FramePoseVector with X_LT and X_LC, for SceneGraph.
    """

    def __init__(
        self,
        scene_graph: SceneGraph,
        meshcat: Meshcat,
        config: SceneConfig,
        geometry: SceneGeometry | None = None,
        prefix: str = "rpod",
    ):
        """Registers the body geometry with `scene_graph` and keeps `meshcat` for overlays.

        Args:
            scene_graph: SceneGraph that receives the target and chaser frames and boxes.
            meshcat: where the overlays are drawn.
            config: how to draw; validated here.
            geometry: what to draw (default: SceneGeometry()); validated here.
            prefix: Meshcat path prefix; overlays go under "<prefix>/overlay".
        """
        super().__init__()
        geometry = geometry if geometry is not None else SceneGeometry()
        config.validate()
        geometry.validate()
        self._config = config
        self._geometry = geometry
        self._meshcat = meshcat
        self._overlay_path = f"{prefix}/overlay"
        self._bodies_path = f"{prefix}/bodies"

        self._sensed_port = declare_sensed_input(self)

        # Kept for RegisterTargetGeometry (extra geometry fixed in T, e.g. paper 004's corridor).
        self._scene_graph = scene_graph
        self._source_id = scene_graph.RegisterSource("rpod_scene")
        self._target_frame_id = self._RegisterBody(
            scene_graph,
            "target",
            body_shape("target", geometry.target_box_size_m, geometry.target_vertices_T),
            geometry.body_extent_m("target"),
            TARGET_RGBA,
        )
        self._chaser_frame_id = self._RegisterBody(
            scene_graph,
            "chaser",
            body_shape("chaser", geometry.chaser_box_size_m, geometry.chaser_vertices_C),
            geometry.body_extent_m("chaser"),
            CHASER_RGBA,
        )

        input_tickets = {self.input_port_ticket(self._sensed_port.get_index())}
        self._pose_port = self.DeclareAbstractOutputPort(
            "geometry_pose",
            lambda: AbstractValue.Make(FramePoseVector()),
            self._CalcFramePoses,
            prerequisites_of_calc=input_tickets,
        )

        self.DeclareInitializationPublishEvent(self._Initialize)
        # Published by the diagram's SceneDriver from the Simulator's monitor, never by an
        # event of its own: a periodic event would add steps and change the physics.
        self.scene_publish_period_s = config.publish_period_s

        # Trail bookkeeping (see module docstring); reset in _Initialize.
        self._trail_p_LC_L = np.zeros((config.trail_max_points, 3))
        self._trail_count = 0
        self._publish_count = 0
        self._last_publish_time = -np.inf
        self._last_trail_time = -np.inf

    def _RegisterBody(self, scene_graph: SceneGraph, name: str, shape, extent_m: float, rgba: Rgba):
        """Registers a frame with a body shape and a body-axes triad; returns the FrameId."""
        frame_id = scene_graph.RegisterFrame(self._source_id, GeometryFrame(name))
        suffix = "box" if isinstance(shape, Box) else "hull"
        box_id = scene_graph.RegisterGeometry(
            self._source_id,
            frame_id,
            GeometryInstance(RigidTransform(), shape, f"{name}_{suffix}"),
        )
        scene_graph.AssignRole(self._source_id, box_id, MakePhongIllustrationProperties(rgba.rgba))
        # Triad length 0.8 of the largest edge, so it sticks out of a cube-like box.
        length = 0.8 * extent_m
        radius = 0.02 * extent_m
        for axis, axis_name in enumerate("xyz"):
            axis_id = scene_graph.RegisterGeometry(
                self._source_id,
                frame_id,
                GeometryInstance(
                    _axis_cylinder_pose(axis, length),
                    Cylinder(radius, length),
                    f"{name}_{axis_name}_axis",
                ),
            )
            scene_graph.AssignRole(
                self._source_id, axis_id, MakePhongIllustrationProperties(AXIS_RGBA[axis].rgba)
            )
        return frame_id

    def RegisterTargetGeometry(
        self, name: str, shape, X_TG: RigidTransform, rgba: Rgba
    ) -> GeometryId:
        """Registers a shape fixed in the target frame T, drawn like the bodies (illustration).

        The geometry G follows X_LT in the live view and in recordings. Call it before a
        context of the diagram is created (SceneGraph copies its model into each new context).

        Args:
            name: geometry name, unique on the target frame; Meshcat shows it under the
                visualizer's prefix, then "target/<name>".
            shape: any SceneGraph shape (Convex, Sphere, Cylinder, ...).
            X_TG: pose of the shape's frame G in T.
            rgba: colour; an alpha below 1 draws it translucent.

        Returns:
            The GeometryId.
        """
        geometry_id = self._scene_graph.RegisterGeometry(
            self._source_id, self._target_frame_id, GeometryInstance(X_TG, shape, name)
        )
        self._scene_graph.AssignRole(
            self._source_id, geometry_id, MakePhongIllustrationProperties(rgba.rgba)
        )
        return geometry_id

    def get_geometry_pose_output_port(self) -> OutputPort:
        """FramePoseVector output for SceneGraph."""
        return self._pose_port

    def source_id(self):
        """SceneGraph SourceId of the bodies."""
        return self._source_id

    def target_frame_id(self):
        """SceneGraph FrameId of the target body frame T."""
        return self._target_frame_id

    def chaser_frame_id(self):
        """SceneGraph FrameId of the chaser body frame C."""
        return self._chaser_frame_id

    def CalcPoses(self, context) -> tuple[RigidTransform, RigidTransform]:
        """Returns (X_LT, X_LC) from the inputs."""
        sensed = Sensed.from_vector(self._sensed_port.Eval(context))
        R_IL = rotation_from_wxyz(sensed.q_IL)
        R_IT = rotation_from_wxyz(sensed.q_IT)
        R_IC = rotation_from_wxyz(sensed.q_IC)
        p_LC_L = sensed.p_LC_L
        return (
            RigidTransform(RotationMatrix(R_IL.T @ R_IT), np.zeros(3)),
            RigidTransform(RotationMatrix(R_IL.T @ R_IC), p_LC_L),
        )

    def _CalcFramePoses(self, context, output: AbstractValue) -> None:
        X_LT, X_LC = self.CalcPoses(context)
        poses = output.get_mutable_value()
        poses.clear()
        poses.set_value(self._target_frame_id, X_LT)
        poses.set_value(self._chaser_frame_id, X_LC)

    def _Initialize(self, context) -> None:
        """Creates the overlay objects, hides the trail pool, and publishes the first state."""
        meshcat, config, root = self._meshcat, self._config, self._overlay_path
        geometry = self._geometry
        t = context.get_time()
        meshcat.Delete(root)

        # LVLH triad at the origin (static).
        radius = 0.015 * config.lvlh_axis_length_m
        for axis, axis_name in enumerate("xyz"):
            path = f"{root}/lvlh_triad/{axis_name}"
            meshcat.SetObject(path, Cylinder(radius, config.lvlh_axis_length_m), AXIS_RGBA[axis])
            meshcat.SetTransform(path, _axis_cylinder_pose(axis, config.lvlh_axis_length_m))

        # Docking port, docking axis and corridor, fixed in T under the target node.
        target = f"{root}/target_frame"
        p_TP_T = np.asarray(geometry.docking_port_T, dtype=float)
        X_TK = RigidTransform(RotationMatrix.MakeFromOneVector(geometry.docking_axis_T, 2), p_TP_T)
        port_radius = 0.06 * geometry.body_extent_m("target")
        meshcat.SetObject(f"{target}/docking_port", Sphere(port_radius), DOCKING_AXIS_RGBA)
        meshcat.SetTransform(f"{target}/docking_port", RigidTransform(p_TP_T))
        axis_length = 1.1 * geometry.corridor_length_m
        meshcat.SetObject(
            f"{target}/docking_axis", Cylinder(0.3 * port_radius, axis_length), DOCKING_AXIS_RGBA
        )
        meshcat.SetTransform(
            f"{target}/docking_axis", X_TK @ RigidTransform([0.0, 0.0, axis_length / 2.0])
        )
        height = geometry.corridor_length_m
        base_radius = height * np.tan(np.radians(geometry.corridor_half_angle_deg))
        meshcat.SetObject(
            f"{target}/corridor/cone", MeshcatCone(height, base_radius, base_radius), CORRIDOR_RGBA
        )
        meshcat.SetTransform(f"{target}/corridor", X_TK)
        angles = np.linspace(0.0, 2.0 * np.pi, 33)
        rim_K = np.vstack(
            [
                base_radius * np.cos(angles),
                base_radius * np.sin(angles),
                np.full_like(angles, height),
            ]
        )
        generators = rim_K[:, :-1:4]
        meshcat.SetLineSegments(
            f"{target}/corridor/edges",
            np.hstack([np.zeros_like(generators), rim_K[:, :-1]]),
            np.hstack([generators, rim_K[:, 1:]]),
            2.0,
            CORRIDOR_EDGE_RGBA,
        )

        # Trail pool, hidden from the start of the recording.
        self._trail_count = 0
        self._publish_count = 0
        self._last_publish_time = -np.inf
        self._last_trail_time = -np.inf
        if config.trail:
            marker = Sphere(config.trail_marker_radius_m)
            for i in range(config.trail_max_points):
                path = self._TrailPath(i)
                meshcat.SetObject(path, marker, TRAIL_RGBA)
                meshcat.SetProperty(path, "visible", False, time_in_recording=t)
        self.PublishScene(context)

    def _TrailPath(self, i: int) -> str:
        return f"{self._overlay_path}/trail/{i:05d}"

    def PublishScene(self, context) -> None:
        """Moves the target node and adds a trail marker; idempotent at a repeated time."""
        t = context.get_time()
        if t <= self._last_publish_time:
            return  # Initialization and the driver both publish at the start time.
        self._last_publish_time = t
        X_LT, X_LC = self.CalcPoses(context)
        self._meshcat.SetTransform(f"{self._overlay_path}/target_frame", X_LT, time_in_recording=t)
        if self._config.trail and self._publish_count % self._config.trail_stride == 0:
            self._AddTrailMarker(t, X_LC.translation())
        self._publish_count += 1

    def _AddTrailMarker(self, t: float, p_LC_L: np.ndarray) -> None:
        meshcat, pool_size = self._meshcat, self._config.trail_max_points
        slot = self._trail_count % pool_size
        path = self._TrailPath(slot)
        if self._trail_count >= pool_size:
            # Reuse the oldest marker: hide and pin it at the previous marker time, so the
            # replay's interpolation moves it only while it is hidden.
            t_previous = self._last_trail_time
            meshcat.SetProperty(path, "visible", False, time_in_recording=t_previous)
            meshcat.SetTransform(
                path, RigidTransform(self._trail_p_LC_L[slot]), time_in_recording=t_previous
            )
        meshcat.SetTransform(path, RigidTransform(p_LC_L), time_in_recording=t)
        meshcat.SetProperty(path, "visible", True, time_in_recording=t)
        self._trail_p_LC_L[slot] = p_LC_L
        self._trail_count += 1
        self._last_trail_time = t

    @staticmethod
    def AddToBuilder(
        builder: DiagramBuilder,
        meshcat: Meshcat,
        config: SceneConfig,
        sensed: OutputPort,
        geometry: SceneGeometry | None = None,
        scene_graph: SceneGraph | None = None,
        name: str = "scene",
        prefix: str = "rpod",
    ) -> "RendezvousScene":
        """Adds the scene, a SceneGraph (unless given) and a MeshcatVisualizer, and wires them.

        Systems are named `name`, `name + ".scene_graph"` and `name + ".meshcat_visualizer"`.
        The visualizer draws under "<prefix>/bodies" at `config.publish_period_s`; overlays go
        under "<prefix>/overlay" (relative Meshcat paths, i.e. below "/drake"). Sets the Meshcat
        camera (if `config.camera_position_L_m` is given) and background visibility.

        Args:
            builder: the diagram builder holding the sensed port.
            meshcat: Meshcat to draw in.
            config: how to draw (a scenario's `visualization` block).
            sensed: the sensed bundle's port (33, rpod.systems.sensed).
            geometry: what to draw (default: SceneGeometry()).
            scene_graph: an existing SceneGraph in `builder` to register with; a new one is
                added when None.
            name: name of the scene system in the diagram.
            prefix: Meshcat path prefix.

        Returns:
            The RendezvousScene.
        """
        if scene_graph is None:
            scene_graph = builder.AddNamedSystem(f"{name}.scene_graph", SceneGraph())
        scene = builder.AddNamedSystem(
            name, RendezvousScene(scene_graph, meshcat, config, geometry, prefix)
        )
        builder.Connect(sensed, scene.GetInputPort(SENSED_PORT))
        builder.Connect(
            scene.get_geometry_pose_output_port(),
            scene_graph.get_source_pose_port(scene.source_id()),
        )
        params = MeshcatVisualizerParams()
        # No periodic event (it would add integrator steps): the SceneDriver force-publishes
        # the visualizer at the scene's period, from the Simulator's monitor.
        params.publish_period = math.inf
        params.prefix = scene._bodies_path
        visualizer = builder.AddNamedSystem(
            f"{name}.meshcat_visualizer", MeshcatVisualizer(meshcat, params)
        )
        scene.visualizer = visualizer
        builder.Connect(scene_graph.get_query_output_port(), visualizer.query_object_input_port())
        meshcat.SetProperty("/Background", "visible", config.meshcat_background)
        return scene

    def FrameCamera(self, p_LC_L_samples: np.ndarray) -> None:
        """Points the camera at what the run drew, sets the far plane behind it, marks small bodies.

        With `camera_position_L_m` empty (the default) the camera looks at the centre of the
        box holding the target and every chaser position of the run, from the direction
        `camera_direction_L`, far enough that the box's bounding sphere fills the view; given,
        it sits there and looks at that centre. Either way the far plane lies beyond the whole
        content (Meshcat's default far plane is 100 m: a 150 m approach would open blank).

        A body that this camera would show less than LOCATOR_PIXELS across (a 1 m chaser
        300 m out is one pixel) gets a locator: a translucent sphere of its colour,
        LOCATOR_PIXELS across at the content's distance, that moves with it. The trail markers
        grow to at least a pixel. The bodies themselves keep their true size.

        Args:
            p_LC_L_samples: the chaser's logged positions (N, 3) in L [m].
        """
        config = self._config
        extent = max(self._geometry.body_extent_m("target"), self._geometry.body_extent_m("chaser"))
        points = np.vstack([np.zeros((1, 3)), np.asarray(p_LC_L_samples, float).reshape(-1, 3)])
        low = points.min(axis=0) - extent
        high = points.max(axis=0) + extent
        centre = 0.5 * (low + high)
        radius = max(0.5 * float(np.linalg.norm(high - low)), extent)
        if len(config.camera_position_L_m) == 3:
            camera = np.asarray(config.camera_position_L_m, dtype=float)
        else:
            direction = np.asarray(config.camera_direction_L, dtype=float)
            # The sphere fits the vertical field of view with 10 % to spare.
            distance = 1.1 * radius / math.sin(math.radians(CAMERA_FOV_DEG / 2.0))
            camera = centre + distance * direction / np.linalg.norm(direction)
        reach = float(np.linalg.norm(camera - centre)) + radius
        near = max(1e-3, min(0.01 * reach, 0.1))
        self._meshcat.SetCamera(
            Meshcat.PerspectiveCamera(fov=CAMERA_FOV_DEG, near=near, far=2.0 * reach)
        )
        self._meshcat.SetCameraPose(camera, centre)

        # One pixel at the content's centre, in a window NOMINAL_VIEW_PIXELS high.
        pixel_m = (
            2.0
            * float(np.linalg.norm(camera - centre))
            * math.tan(math.radians(CAMERA_FOV_DEG / 2.0))
            / NOMINAL_VIEW_PIXELS
        )
        for body, rgba in (("target", TARGET_RGBA), ("chaser", CHASER_RGBA)):
            if self._geometry.body_extent_m(body) < LOCATOR_PIXELS * pixel_m:
                self._meshcat.SetObject(
                    f"{self._bodies_path}/{body}/locator",
                    Sphere(0.5 * LOCATOR_PIXELS * pixel_m),
                    Rgba(rgba.r(), rgba.g(), rgba.b(), LOCATOR_ALPHA),
                )
        if config.trail and config.trail_marker_radius_m < pixel_m:
            marker = Sphere(pixel_m)
            for i in range(config.trail_max_points):
                self._meshcat.SetObject(self._TrailPath(i), marker, TRAIL_RGBA)


class SceneDriver:
    """Publishes a diagram's scene systems from the Simulator's monitor, never by events.

    A periodic publish event makes the integrator end a step at its time, so a scene drawn
    that way changes the physics it shows (a recorded run differed from the same run
    unrecorded: 801 against 402 steps, 13.60 against 13.75 m/s of delta-v). The driver is
    called after every integrator step (simulate sets it as part of the Simulator's
    monitor) and publishes each system at the first step end at or after each multiple of
    its period, stamped with that step's true time. Steps end at every log sample, control
    period and PWM slot, so a scene whose period is a multiple of the log period is drawn on
    time; a shorter one is drawn at the step ends (at most once per step).

    Systems it drives: any with `scene_publish_period_s` and `PublishScene(context)`
    (RendezvousScene, PlannedPathOverlay, the method scenes), and MeshcatVisualizers
    (force-published at the period of the scene that added them).
    """

    def __init__(self):
        self._entries = []  # [system, period_s, publish, next_time_s, last_time_s]

    def add(self, system, period_s: float, publish) -> None:
        """Publishes `system` by `publish(its context)` every `period_s` of simulated time."""
        self._entries.append([system, float(period_s), publish, 0.0, -math.inf])

    @classmethod
    def for_systems(cls, systems) -> "SceneDriver":
        """A driver of every scene system among `systems` (e.g. builder.GetSystems())."""
        driver = cls()
        for system in systems:
            if hasattr(system, "PublishScene") and hasattr(system, "scene_publish_period_s"):
                driver.add(system, system.scene_publish_period_s, system.PublishScene)
                visualizer = getattr(system, "visualizer", None)
                if visualizer is not None:
                    driver.add(visualizer, system.scene_publish_period_s, visualizer.ForcedPublish)
        return driver

    def __len__(self) -> int:
        return len(self._entries)

    def attach(self, simulator) -> "SceneDriver":
        """Makes this driver the simulator's monitor (for a diagram drawn on its own; rpod's
        simulate chains it with its other per-step checks instead). Returns self."""

        def monitor(root_context):
            self.observe(root_context)
            return EventStatus.Succeeded()

        simulator.set_monitor(monitor)
        return self

    def observe(self, root_context) -> None:
        """Publishes what is due at this step end (root_context: the diagram's)."""
        t = root_context.get_time()
        for entry in self._entries:
            system, period, publish, due, _ = entry
            if t >= due - 1e-9 * max(1.0, abs(due)):
                publish(system.GetMyContextFromRoot(root_context))
                entry[3] = period * (math.floor(t / period + 1e-9) + 1.0)
                entry[4] = t

    def finish(self, root_context) -> None:
        """Publishes every system at the run's last instant, unless it already has."""
        t = root_context.get_time()
        for entry in self._entries:
            system, _, publish, _, last = entry
            if last < t:
                publish(system.GetMyContextFromRoot(root_context))
                entry[4] = t


class PlannedPathOverlay(LeafSystem):
    """Draws each new plan's knots in Meshcat (module docstring), in L.

    Input port:
        planned_path (abstract): an object with ``index`` (int; 0 = no plan), ``t0_s`` (float)
            and ``p_LC_L`` ((N, 3) array): ``rpod.systems.plan_at_start.PlannedPath``. A new
            ``index`` is drawn at the next publish.

    Args:
        meshcat: where to draw.
        publish_period_s: how often the input is checked [s].
        prefix: Meshcat path prefix; the plans go under "<prefix>/overlay/plans".
        knot_size_m: size of the knot points [m].
    """

    def __init__(
        self,
        meshcat: Meshcat,
        publish_period_s: float,
        prefix: str = "rpod",
        knot_size_m: float = 0.12,
    ):
        super().__init__()
        self._meshcat = meshcat
        self._root = f"{prefix}/overlay/plans"
        self._knot_size = knot_size_m
        self._path_port = self.DeclareAbstractInputPort(
            "planned_path", AbstractValue.Make(object())
        )
        self.DeclareInitializationPublishEvent(self._Initialize)
        # Published by the diagram's SceneDriver from the Simulator's monitor, never by an
        # event of its own: a periodic event would add steps and change the physics.
        self.scene_publish_period_s = publish_period_s
        self._drawn_index = 0
        self._start_time = 0.0

    def _Initialize(self, context) -> None:
        self._meshcat.Delete(self._root)
        self._drawn_index = 0
        self._start_time = context.get_time()
        self.PublishScene(context)

    def PublishScene(self, context) -> None:
        path = self._path_port.Eval(context)
        index = int(getattr(path, "index", 0))
        if index == self._drawn_index or index == 0:
            return
        t = context.get_time()
        p = np.asarray(path.p_LC_L, dtype=float)
        node = f"{self._root}/{index:03d}"
        if len(p) >= 2:
            self._meshcat.SetLine(f"{node}/line", p.T, 2.0, PLAN_RGBA)
        cloud = PointCloud(len(p), Fields(BaseField.kXYZs))
        cloud.mutable_xyzs()[:] = p.T
        self._meshcat.SetObject(f"{node}/knots", cloud, self._knot_size, PLAN_RGBA)
        # Hidden from the recording's start until now; the previous plan is hidden from now on.
        self._meshcat.SetProperty(node, "visible", False, time_in_recording=self._start_time)
        self._meshcat.SetProperty(node, "visible", True, time_in_recording=t)
        if self._drawn_index:
            previous = f"{self._root}/{self._drawn_index:03d}"
            self._meshcat.SetProperty(previous, "visible", False, time_in_recording=t)
        self._drawn_index = index
