"""Paper 001's coupled NMPC in the Meshcat scene: the LOS pyramid, the feature points, the thrust.

Owns: what the coupled 6-DOF NMPC adds to `RendezvousScene` (rpod.systems.scene), through one
entry, `add_coupled_scene`:
- the LOS polyhedron of eq. 18, { p : A_p (p - p_TPt_T) <= 0 } with A_p of
  `rpod.models.coupled_relative.los_polyhedron`, a 4-face pyramid with its apex at the rock Pt,
  drawn translucent with its four edges, cut at `los_length_m` along its axis p_TPt_T/|p_TPt_T|;
- the rock Pt (a sphere at p_TPt_T): these two are SceneGraph geometry on the scene's target frame
  (`RegisterTargetGeometry`), so they turn with the target live and in the recording;
- the end effector Pc (a sphere at p_CPc_C) and one arrow per thruster, drawn by `ThrustArrows`.
Does not own: the scene, its SceneGraph or Meshcat (rpod.systems.scene), the recording
(rpod.diagrams.recording), the model (rpod.models.coupled_relative, rpod.models.thrusters) or
the forces (the controller and the thrusters that apply them).

The pyramid's edges are computed from the rows of A_p, not from how los_polyhedron built them:
each edge is a ray from the apex along r_i x r_j for two rows whose line lies in every other
row's half-space (A_p d <= 0), i.e. an adjacent pair; for the pyramid of half-angle alpha it
opens at atan(sqrt(2) tan(alpha)) from the axis (54.7 deg for Sec. IV's pi/4). The drawn solid is
the convex hull of the apex and the four edge points at distance `los_length_m` along the axis.

Thrust arrows (`ThrustArrows`, a LeafSystem): there is no chaser-frame registration in the
scene, and an arrow's length changes, which SceneGraph geometry cannot do; so they are drawn
directly in Meshcat under "<prefix>/coupled_nmpc/chaser", a node whose transform is X_LC, read
from the scene's own `geometry_pose` output (the pose its chaser body is drawn with). Below it,
fixed in C, the end-effector sphere and, for thruster k, a node at p_CK_C whose +z axis is the
arrow's direction, holding a shaft (a unit cylinder under a node scaled along z) and a cone head
(moved to the tip, scaled down uniformly when the arrow is shorter than the head). Each arrow
starts at the thruster and points along the exhaust, -f_k/|f_k| (the plume, out of the chaser:
the force on the chaser, f_k, points into the body at the paper's corner thrusters and would be
hidden by it); `exhaust=False` draws f_k itself. Length metres_per_newton |f_k| (0.1 m/N: 2 m at
Sec. IV's f_max of 20 N); an arrow below `min_force_N` (default 1 mN) is hidden. The forces
drawn are those of the input port; with `clip=True` the port may carry the commands instead, and
the arrows show what the thruster bank applies: the commands mapped into the layout's limits by
the bank's own rule (`GimbalLimits.clip`, eqs. 16-17), evaluated only at the publishes.

Updates: at initialization and every `publish_period_s` of simulated time (the diagram's
SceneDriver calls `PublishScene`; pass the scene's period,
so the arrows move with the bodies), every call carrying time_in_recording = t, so a recording
started before `Simulator.Initialize` replays them (rpod.diagrams.recording). Scale goes on a node
that never receives a transform (Meshcat's set_transform resets a node's scale). Per publish:
one transform for the chaser node, four calls per shown thruster, and a visibility call when a
thruster turns on or off. The root is deleted and rebuilt at initialization; it is outside the
scene's "<prefix>/overlay", which the scene deletes at its own initialization.
"""

import itertools

import numpy as np
from pydrake.common import MemoryFile
from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    Convex,
    Cylinder,
    FramePoseVector,
    GeometryId,
    InMemoryMesh,
    Meshcat,
    MeshcatCone,
    Rgba,
    Sphere,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import DiagramBuilder, OutputPort

from rpod.models.coupled_relative import los_polyhedron
from rpod.models.gimbal import GimbalLimits
from rpod.models.thrusters import ThrusterLayout
from rpod.systems.lifetime import LeafSystem
from rpod.systems.scene import RendezvousScene, convex_hull_obj

LOS_PYRAMID_RGBA = Rgba(0.55, 0.30, 0.85, 0.20)
LOS_PYRAMID_EDGE_RGBA = Rgba(0.40, 0.15, 0.70, 1.0)
ROCK_RGBA = Rgba(0.95, 0.20, 0.20, 1.0)
END_EFFECTOR_RGBA = Rgba(0.10, 0.80, 0.90, 1.0)
PLUME_RGBA = Rgba(1.00, 0.55, 0.00, 1.0)

_TOLERANCE = 1e-9  # a row product above -this counts as on the plane (unit rows, unit d)
_MIN_SHAFT = 1e-6  # a zero scale makes a singular matrix: the shaft keeps this much


def los_pyramid_edge_directions(A_p: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """(m, 3) unit directions of the edges of the cone { v : A_p v <= 0 }, ordered by angle about
    `axis` (module docstring): each is +-(r_i x r_j) for two rows with A_p d <= 0."""
    A = np.asarray(A_p, dtype=float)
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    edges = []
    for i, j in itertools.combinations(range(len(A)), 2):
        d = np.cross(A[i], A[j])
        norm = np.linalg.norm(d)
        if norm < _TOLERANCE:
            continue  # parallel planes
        for candidate in (d / norm, -d / norm):
            if np.all(A @ candidate <= _TOLERANCE):  # only one of +-d is in the cone
                edges.append(candidate)
    edges = np.asarray(edges)
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    return edges[np.argsort(np.arctan2(edges @ e2, edges @ e1))]


def los_pyramid_vertices(p_TPt_T, half_angle_rad: float, length_m: float) -> np.ndarray:
    """Vertices in T [m] of eq. 18's pyramid cut at `length_m` along its axis: (5, 3), the apex
    (the rock, p_TPt_T) then the four cap corners, ordered by angle about the axis."""
    if not (np.isfinite(length_m) and length_m > 0.0):
        raise ValueError(f"length_m must be positive, got {length_m}")
    p = np.asarray(p_TPt_T, dtype=float)
    axis = p / np.linalg.norm(p)  # los_polyhedron's axis: the rock's outward radial direction
    A_p = los_polyhedron(p, half_angle_rad)  # eq. 18: A_p p_PtPc_T <= 0
    directions = los_pyramid_edge_directions(A_p, axis)
    return np.vstack([p, p + directions * (length_m / (directions @ axis))[:, None]])


def add_los_pyramid_to_scene(
    scene: RendezvousScene,
    p_TPt_T,
    half_angle_rad: float,
    length_m: float,
    *,
    rgba: Rgba = LOS_PYRAMID_RGBA,
    edge_rgba: Rgba | None = LOS_PYRAMID_EDGE_RGBA,
    rock_rgba: Rgba = ROCK_RGBA,
    rock_radius_m: float | None = None,
    name: str = "coupled",
) -> dict[str, GeometryId]:
    """Registers eq. 18's LOS pyramid, its edges and the rock on the scene's target frame.

    Call it after `RendezvousScene.AddToBuilder` and before a context of the diagram is made.

    Args:
        scene: the scene whose target frame receives the geometry.
        p_TPt_T: the rock Pt from the target's CoM, in T (3,) [m]: the apex.
        half_angle_rad: the pyramid's angle (eq. 18; Sec. IV: pi/4).
        length_m: where the pyramid is cut, along its axis from the apex [m].
        rgba: the pyramid's colour (translucent by default).
        edge_rgba: the colour of thin cylinders along its 4 edges, or None for none.
        rock_rgba: the rock sphere's colour.
        rock_radius_m: its radius; default max(0.1, 0.01 length_m) [m].
        name: the geometry names' stem, unique on the target frame.

    Returns:
        The GeometryIds by name: `name + "_los"`, `name + "_los_edge_<k>"` (k = 0..3),
        `name + "_rock"`.
    """
    p = np.asarray(p_TPt_T, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)) or np.linalg.norm(p) == 0.0:
        raise ValueError(f"p_TPt_T must be 3 finite numbers, not all 0, got {p_TPt_T}")
    vertices = los_pyramid_vertices(p, half_angle_rad, length_m)
    stem = f"{name}_los"
    mesh = InMemoryMesh(mesh_file=MemoryFile(convex_hull_obj(vertices), ".obj", f"{stem}.obj"))
    ids = {stem: scene.RegisterTargetGeometry(stem, Convex(mesh), RigidTransform(), rgba)}
    if edge_rgba is not None:
        for k, corner in enumerate(vertices[1:]):
            along = corner - p
            X_TE = RigidTransform(RotationMatrix.MakeFromOneVector(along, 2), (p + corner) / 2.0)
            edge = f"{stem}_edge_{k}"
            ids[edge] = scene.RegisterTargetGeometry(
                edge, Cylinder(0.003 * length_m, np.linalg.norm(along)), X_TE, edge_rgba
            )
    radius = rock_radius_m if rock_radius_m is not None else max(0.1, 0.01 * length_m)
    rock = f"{name}_rock"
    ids[rock] = scene.RegisterTargetGeometry(rock, Sphere(radius), RigidTransform(p), rock_rgba)
    return ids


def thrust_arrows_C(
    layout: ThrusterLayout,
    f_K_C: np.ndarray,
    metres_per_newton: float,
    *,
    exhaust: bool = True,
    min_force_N: float = 1e-3,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each thruster's arrow starts, which way it points, and how long it is, in C.

    Args:
        layout: the thrusters (their positions p_CK_C and nominal directions).
        f_K_C: force of each thruster on the chaser, in C, (3 n,) stacked or (n, 3) [N].
        metres_per_newton: arrow length per newton [m/N].
        exhaust: True: along the exhaust, -f_k/|f_k|; False: along f_k (module docstring).
        min_force_N: a force of at most this magnitude gives length 0 and the nominal direction.

    Returns:
        (origins (n, 3) = p_CK_C [m], unit directions (n, 3), lengths (n,) [m]).
    """
    F = np.asarray(f_K_C, dtype=float).reshape(layout.count, 3)
    magnitude = np.linalg.norm(F, axis=1)
    on = magnitude > min_force_N
    sign = -1.0 if exhaust else 1.0
    nominal = sign * layout.directions_C
    directions = np.where(on[:, None], sign * F / np.where(on, magnitude, 1.0)[:, None], nominal)
    lengths = np.where(on, metres_per_newton * magnitude, 0.0)
    return layout.p_CK_C, directions, lengths


class ThrustArrows(LeafSystem):
    """Draws the end effector and each thruster's force as an arrow on the chaser in Meshcat.

    Input ports:
        thruster_forces_C (3 n): the applied force of each thruster on the chaser, in C [N].
        geometry_pose (abstract FramePoseVector): the scene's poses; X_LC is read from the
            chaser frame's.

    Everything is drawn under "<prefix>/coupled_nmpc/chaser" (module docstring).
    """

    def __init__(
        self,
        meshcat: Meshcat,
        layout: ThrusterLayout,
        chaser_frame_id,
        p_CPc_C,
        publish_period_s: float,
        *,
        metres_per_newton: float = 0.1,
        exhaust: bool = True,
        min_force_N: float = 1e-3,
        clip: bool = False,
        prefix: str = "rpod",
        shaft_radius_m: float = 0.03,
        head_length_m: float = 0.15,
        end_effector_radius_m: float = 0.1,
    ):
        """Declares the ports and the publish events.

        Args:
            meshcat: where to draw.
            layout: the thrusters (n of them).
            chaser_frame_id: the scene's chaser FrameId (`RendezvousScene.chaser_frame_id()`).
            p_CPc_C: the end effector Pc from the chaser's CoM, in C (3,) [m].
            publish_period_s: update period in simulated time [s] (the scene's).
            metres_per_newton: arrow length per newton [m/N].
            exhaust: arrows along the exhaust (True) or along the force on the chaser.
            min_force_N: arrows of a smaller force are hidden [N].
            clip: the input carries commands: draw them clipped to the layout's limits as the
                thruster bank applies them (module docstring).
            prefix: Meshcat path prefix, as the scene's.
            shaft_radius_m: arrow shaft radius [m]; the head is 2.5 times as wide.
            head_length_m: arrow head length [m].
            end_effector_radius_m: the end-effector sphere's radius [m].
        """
        super().__init__()
        p = np.asarray(p_CPc_C, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ValueError(f"p_CPc_C must be 3 finite numbers, got {p_CPc_C}")
        for value, what in (
            (publish_period_s, "publish_period_s"),
            (metres_per_newton, "metres_per_newton"),
            (shaft_radius_m, "shaft_radius_m"),
            (head_length_m, "head_length_m"),
            (end_effector_radius_m, "end_effector_radius_m"),
        ):
            if not (np.isfinite(value) and value > 0.0):
                raise ValueError(f"{what} must be positive, got {value}")
        self._meshcat = meshcat
        self._layout = layout
        self._chaser_frame_id = chaser_frame_id
        self._p_CPc_C = p
        self._metres_per_newton = metres_per_newton
        self._exhaust = exhaust
        self._min_force_N = min_force_N
        self._limits = GimbalLimits(layout) if clip else None
        self._shaft_radius = shaft_radius_m
        self._head_length = head_length_m
        self._end_effector_radius = end_effector_radius_m
        self._root = f"{prefix}/coupled_nmpc"
        self._chaser_path = f"{self._root}/chaser"

        self._forces_port = self.DeclareVectorInputPort("thruster_forces_C", 3 * layout.count)
        self._poses_port = self.DeclareAbstractInputPort(
            "geometry_pose", AbstractValue.Make(FramePoseVector())
        )
        self.DeclareInitializationPublishEvent(self._Initialize)
        # Published by the diagram's SceneDriver from the Simulator's monitor, never by an
        # event of its own: a periodic event would add steps and change the physics.
        self.scene_publish_period_s = publish_period_s

        # Bookkeeping, reset by _Initialize (as RendezvousScene's trail).
        self._shown = np.zeros(layout.count, dtype=bool)
        self._last_publish_time = -np.inf

    def get_thruster_forces_input_port(self):
        """thruster_forces_C (3 n)."""
        return self._forces_port

    def get_geometry_pose_input_port(self):
        """geometry_pose (FramePoseVector): connect the scene's geometry_pose output."""
        return self._poses_port

    def thruster_path(self, k: int) -> str:
        """Meshcat path of thruster k's arrow node (relative to /drake)."""
        return f"{self._chaser_path}/thrusters/{k}"

    def _Initialize(self, context) -> None:
        """Creates the end effector and the arrows (hidden until a force shows them)."""
        meshcat, t = self._meshcat, context.get_time()
        meshcat.Delete(self._root)
        end_effector = f"{self._chaser_path}/end_effector"
        meshcat.SetObject(end_effector, Sphere(self._end_effector_radius), END_EFFECTOR_RGBA)
        meshcat.SetTransform(end_effector, RigidTransform(self._p_CPc_C))
        head = MeshcatCone(self._head_length, 2.5 * self._shaft_radius, 2.5 * self._shaft_radius)
        flip = RigidTransform(RotationMatrix.MakeXRotation(np.pi))  # apex at the tip, opens -z
        for k in range(self._layout.count):
            path = self.thruster_path(k)
            meshcat.SetObject(
                f"{path}/shaft/cylinder", Cylinder(self._shaft_radius, 1.0), PLUME_RGBA
            )
            meshcat.SetTransform(f"{path}/shaft/cylinder", RigidTransform([0.0, 0.0, 0.5]))
            meshcat.SetObject(f"{path}/head/size/cone", head, PLUME_RGBA)
            meshcat.SetTransform(f"{path}/head/size/cone", flip)
            meshcat.SetProperty(path, "visible", False, time_in_recording=t)
        self._shown[:] = False
        self._last_publish_time = -np.inf
        self.PublishScene(context)

    def PublishScene(self, context) -> None:
        """Moves the chaser node and redraws the arrows; idempotent at a repeated time."""
        t = context.get_time()
        if t <= self._last_publish_time:
            return  # Initialization and the periodic event can both fire at the start time.
        self._last_publish_time = t
        meshcat = self._meshcat
        X_LC = self._poses_port.Eval(context).value(self._chaser_frame_id)
        meshcat.SetTransform(self._chaser_path, X_LC, time_in_recording=t)
        F = np.asarray(self._forces_port.Eval(context)).reshape(self._layout.count, 3)
        if self._limits is not None:
            F = self._limits.clip(F)[0]  # the bank's rule (eqs. 16-17)
        origins, directions, lengths = thrust_arrows_C(
            self._layout,
            F,
            self._metres_per_newton,
            exhaust=self._exhaust,
            min_force_N=self._min_force_N,
        )
        for k in range(self._layout.count):
            path = self.thruster_path(k)
            shown = bool(lengths[k] > 0.0)
            if shown != self._shown[k]:
                meshcat.SetProperty(path, "visible", shown, time_in_recording=t)
                self._shown[k] = shown
            if not shown:
                continue  # keeps its last shape while hidden
            length = float(lengths[k])
            size = min(1.0, length / self._head_length)  # the head's share of a short arrow
            shaft = max(length - size * self._head_length, _MIN_SHAFT)
            X_CA = RigidTransform(RotationMatrix.MakeFromOneVector(directions[k], 2), origins[k])
            meshcat.SetTransform(path, X_CA, time_in_recording=t)
            meshcat.SetProperty(f"{path}/shaft", "scale", [1.0, 1.0, shaft], time_in_recording=t)
            meshcat.SetTransform(
                f"{path}/head", RigidTransform([0.0, 0.0, length]), time_in_recording=t
            )
            meshcat.SetProperty(
                f"{path}/head/size", "scale", [size, size, size], time_in_recording=t
            )


def add_coupled_scene(
    builder: DiagramBuilder,
    meshcat: Meshcat,
    scene: RendezvousScene,
    layout: ThrusterLayout,
    p_TPt_T,
    p_CPc_C,
    los_half_angle_rad: float,
    forces_port: OutputPort,
    *,
    publish_period_s: float,
    los_length_m: float = 20.0,
    metres_per_newton: float = 0.1,
    exhaust: bool = True,
    clip: bool = False,
    name: str = "coupled_nmpc_scene",
    prefix: str = "rpod",
) -> ThrustArrows:
    """Adds paper 001's scene extras: LOS pyramid and rock on T, end effector and thrust arrows.

    For a plug-in's `add_scene_extras(builder, meshcat, scenario, wiring, scene)`; call it after
    `RendezvousScene.AddToBuilder` and before `builder.Build()`.

    Args:
        builder: the builder holding `scene` and `forces_port`.
        meshcat: the scene's Meshcat.
        scene: the RendezvousScene (its target frame, chaser frame id and geometry_pose output).
        layout: the thrusters whose forces `forces_port` carries (gimbaled_cuboid_8 in Sec. IV).
        p_TPt_T: the rock Pt from the target's CoM, in T (3,) [m].
        p_CPc_C: the end effector Pc from the chaser's CoM, in C (3,) [m].
        los_half_angle_rad: the LOS pyramid's angle (eq. 18).
        forces_port: an output port in `builder` carrying the 3 n applied forces, in C [N]
            (or the commands, with clip=True).
        publish_period_s: arrow update period [s]: the scene's (scenario.visualization).
        los_length_m: where the drawn pyramid is cut, along its axis from the rock [m].
        metres_per_newton: arrow length per newton [m/N].
        exhaust: arrows along the exhaust (True) or along the force on the chaser.
        clip: `forces_port` carries commands: draw them as the bank clips them (eqs. 16-17);
            `layout` must then carry the bank's limits.
        name: the ThrustArrows system's name in the diagram.
        prefix: Meshcat path prefix, as the scene's.

    Returns:
        The ThrustArrows system.
    """
    add_los_pyramid_to_scene(scene, p_TPt_T, los_half_angle_rad, los_length_m)
    arrows = builder.AddNamedSystem(
        name,
        ThrustArrows(
            meshcat,
            layout,
            scene.chaser_frame_id(),
            p_CPc_C,
            publish_period_s,
            metres_per_newton=metres_per_newton,
            exhaust=exhaust,
            clip=clip,
            prefix=prefix,
        ),
    )
    builder.Connect(forces_port, arrows.get_thruster_forces_input_port())
    builder.Connect(scene.get_geometry_pose_output_port(), arrows.get_geometry_pose_input_port())
    return arrows
