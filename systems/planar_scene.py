"""Paper 003's dynamic keep-out zone (KOS) in the Meshcat scene, State I or II as it switches.

Owns: the outlines of the KOS pieces of each state in the target frame T (`keepout_outlines_T`),
their extrusion into translucent prisms (`prism_mesh`), and `PlanarKeepOutScene`, a LeafSystem
that draws both states' zones on a node that follows the target (X_LT) and shows the one the
chaser's state selects, switching in the live view and in the recording; plus the goal, fixed
in L (`add_planar_scene`; the planned path is drawn by rpod.systems.scene.PlannedPathOverlay).
Does not own: the KOS geometry and its switching rule (rpod.models.planar_approach, whose
`KeepOutGeometry.state` decides the state drawn), the scene, its bodies or its Meshcat
(rpod.systems.scene), or the recording (rpod.diagrams.recording).

The pieces (rpod.models.planar_approach's module docstring, Sec. III-C, Fig. 3), in T, each a
closed convex polygon (counter-clockwise, `points_per_half` points on each curved half):
- State I: the disc |p| < r_safe (eq. 10) and the two half-ellipses E+ and E- (semi-axes r_safe
  along x_T, r_safe / 2 along y_T, centred at y_T = +-(r_safe / 2 + l_margin), the flat side on
  x_T = 0, bulging to the docking side x_T > 0);
- State II: the rear half-disc (x_T < 0) of radius r_safe, the front half-disc (x_T > 0) of
  radius r_relaxed, and the same half-ellipses.
Each piece is drawn as a prism of `height_m` (the target's height) centred on the plane z = 0,
plus its outline at z = 0. The curved sides are inscribed polygons (vertices on the exact
curves, up to 1 - cos(pi / (2 points_per_half)) = 0.05 % inside at 48).

Timing: at initialization and every `publish_period_s` of simulated time (pass the scene's; the
diagram's SceneDriver calls `PublishScene`, no event of its own changes a step),
every call carrying time_in_recording = t: the node's transform X_LT, and the two states'
visibility whenever the chaser's state changes (`KeepOutGeometry.state` of the chaser's centre
in T and its heading from the docking face, the memoryless switching of the model). Drawn under "<prefix>/planar_kos", outside the scene's
"<prefix>/overlay", which the scene deletes at its own initialization.
"""

import math

import numpy as np
from pydrake.geometry import Meshcat, Rgba, Sphere
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import DiagramBuilder, OutputPort

from rpod.models import planar_approach as pa
from rpod.models.frames import rotation_from_wxyz
from rpod.systems.lifetime import LeafSystem
from rpod.systems.sensed import SENSED_PORT, Sensed, declare_sensed_input

STATE_RGBA = {
    pa.STATE_I: Rgba(0.90, 0.20, 0.20, 0.22),
    pa.STATE_II: Rgba(0.15, 0.75, 0.35, 0.22),
}
OUTLINE_RGBA = {
    pa.STATE_I: Rgba(0.75, 0.10, 0.10, 1.0),
    pa.STATE_II: Rgba(0.05, 0.55, 0.20, 1.0),
}
GOAL_RGBA = Rgba(0.85, 0.10, 0.60, 1.0)  # the planned path's colour (rpod.systems.scene)


def _arc(radius_x, radius_y, centre, start, stop, count):
    s = np.linspace(start, stop, count + 1)
    return np.column_stack([centre[0] + radius_x * np.cos(s), centre[1] + radius_y * np.sin(s)])


def keepout_outlines_T(
    geometry: pa.KeepOutGeometry, state: int, points_per_half: int = 48
) -> list[np.ndarray]:
    """The convex pieces of a state's KOS as closed polygons in T, each (M, 2), counter-clockwise
    (module docstring); the last point is not repeated."""
    m = int(points_per_half)
    if m < 2:
        raise ValueError(f"points_per_half must be at least 2, got {points_per_half}")
    a, b = geometry.ellipse_semi_axes_m
    c = geometry.ellipse_offset_m
    half = 0.5 * math.pi
    pieces = []
    if state == pa.STATE_I:
        pieces.append(
            _arc(geometry.r_safe_m, geometry.r_safe_m, (0, 0), 0, 2 * math.pi, 2 * m)[:-1]
        )
    elif state == pa.STATE_II:
        # Half-discs: the arc from one end of the flat side x_T = 0 to the other.
        pieces.append(_arc(geometry.r_safe_m, geometry.r_safe_m, (0, 0), half, 3 * half, m))
        pieces.append(_arc(geometry.r_relaxed_m, geometry.r_relaxed_m, (0, 0), -half, half, m))
    else:
        raise ValueError(f"state must be STATE_I or STATE_II, got {state!r}")
    for sign in (1.0, -1.0):  # (a cos s, +-c + b sin s), s in [-pi/2, pi/2]: x_T >= 0
        pieces.append(_arc(a, b, (0.0, sign * c), -half, half, m))
    return pieces


def prism_mesh(polygon: np.ndarray, height_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(vertices (3, 2M), faces (3, 4M - 4)) of a convex polygon (M, 2) extruded over
    z in [-height_m / 2, height_m / 2]: bottom ring, top ring; fans for the caps, two
    triangles per side."""
    polygon = np.asarray(polygon, float)
    M = len(polygon)
    h = 0.5 * height_m
    vertices = np.vstack(
        [
            np.column_stack([polygon, np.full(M, -h)]),
            np.column_stack([polygon, np.full(M, h)]),
        ]
    ).T
    fan = np.arange(1, M - 1)
    bottom = np.column_stack([np.zeros(M - 2), fan + 1, fan])
    top = np.column_stack([np.full(M - 2, M), M + fan, M + fan + 1])
    k = np.arange(M)
    k1 = (k + 1) % M
    sides = np.vstack([np.column_stack([k, k1, M + k1]), np.column_stack([k, M + k1, M + k])])
    faces = np.vstack([bottom, top, sides]).astype(np.int32).T
    return np.asfortranarray(vertices), np.asfortranarray(faces)


class PlanarKeepOutScene(LeafSystem):
    """Draws both KOS states on the target and shows the chaser's (module docstring).

    Input port:
        sensed (33): the sensed bundle (rpod.systems.sensed): p_LC_L, q_IL, q_IT.
    """

    def __init__(
        self,
        meshcat: Meshcat,
        geometry: pa.KeepOutGeometry,
        publish_period_s: float,
        *,
        height_m: float = 0.3,
        prefix: str = "rpod",
        points_per_half: int = 48,
    ):
        """Declares the port and the publish events.

        Args:
            meshcat: where to draw.
            geometry: the KOS (its sizes and switching rule).
            publish_period_s: update period in simulated time [s] (the scene's).
            height_m: height of the drawn prisms [m] (the target's).
            prefix: Meshcat path prefix, as the scene's.
            points_per_half: points on each curved half of an outline.
        """
        super().__init__()
        for value, what in ((publish_period_s, "publish_period_s"), (height_m, "height_m")):
            if not (np.isfinite(value) and value > 0.0):
                raise ValueError(f"{what} must be positive, got {value}")
        self._meshcat = meshcat
        self._geometry = geometry
        self._height = float(height_m)
        self._points = int(points_per_half)
        self._root = f"{prefix}/planar_kos"
        self._sensed_port = declare_sensed_input(self)
        self.DeclareInitializationPublishEvent(self._Initialize)
        # Published by the diagram's SceneDriver from the Simulator's monitor, never by an
        # event of its own: a periodic event would add steps and change the physics.
        self.scene_publish_period_s = publish_period_s
        self._state = 0  # drawn state, reset by _Initialize
        self._last_publish_time = -np.inf

    @property
    def target_path(self) -> str:
        """Meshcat path of the node that follows the target (relative to /drake)."""
        return f"{self._root}/target"

    def state_path(self, state: int) -> str:
        """Meshcat path of a state's zone (under the target node)."""
        return f"{self.target_path}/state_{state}"

    def pose_and_state(self, context) -> tuple[RigidTransform, int]:
        """(X_LT, the KOS state of the chaser's pose: its centre and its heading from the
        docking face) from the sensed bundle."""
        sensed = Sensed.from_vector(self._sensed_port.Eval(context))
        R_IL = rotation_from_wxyz(sensed.q_IL)
        R_LT = R_IL.T @ rotation_from_wxyz(sensed.q_IT)
        R_LC = R_IL.T @ rotation_from_wxyz(sensed.q_IC)
        p_T = R_LT.T @ sensed.p_LC_L
        heading_error = pa.face_heading_error(
            math.atan2(R_LC[1, 0], R_LC[0, 0]), math.atan2(R_LT[1, 0], R_LT[0, 0])
        )
        state = int(self._geometry.state(p_T[:2], heading_error))
        return RigidTransform(RotationMatrix(R_LT), np.zeros(3)), state

    def _Initialize(self, context) -> None:
        """Creates both zones (the chaser's shown, the other hidden) and publishes."""
        meshcat = self._meshcat
        meshcat.Delete(self._root)
        for state in (pa.STATE_I, pa.STATE_II):
            node = self.state_path(state)
            outlines = keepout_outlines_T(self._geometry, state, self._points)
            for k, polygon in enumerate(outlines):
                vertices, faces = prism_mesh(polygon, self._height)
                meshcat.SetTriangleMesh(f"{node}/piece_{k}", vertices, faces, STATE_RGBA[state])
                ring = np.vstack([polygon, polygon[:1]])
                line = np.column_stack([ring, np.zeros(len(ring))]).T
                meshcat.SetLine(f"{node}/outline_{k}", line, 2.0, OUTLINE_RGBA[state])
        self._state = 0
        self._last_publish_time = -np.inf
        self.PublishScene(context)

    def PublishScene(self, context) -> None:
        """Moves the target node; shows the chaser's state; idempotent at a repeated time."""
        t = context.get_time()
        if t <= self._last_publish_time:
            return  # Initialization and the periodic event can both fire at the start time.
        self._last_publish_time = t
        X_LT, state = self.pose_and_state(context)
        self._meshcat.SetTransform(self.target_path, X_LT, time_in_recording=t)
        if state != self._state:
            for drawn in (pa.STATE_I, pa.STATE_II):
                self._meshcat.SetProperty(
                    self.state_path(drawn), "visible", drawn == state, time_in_recording=t
                )
            self._state = state


def add_planar_scene(
    builder: DiagramBuilder,
    meshcat: Meshcat,
    geometry: pa.KeepOutGeometry,
    sensed: OutputPort,
    *,
    publish_period_s: float,
    goal_L: np.ndarray | None = None,
    height_m: float = 0.3,
    name: str = "planar_kos_scene",
    prefix: str = "rpod",
) -> PlanarKeepOutScene:
    """Adds the switching KOS on the target and draws the goal in L (the planned path is the
    tracker's `planned_path`, drawn by rpod.systems.scene.PlannedPathOverlay once planned).

    For a plug-in's `add_scene_extras`; call it before `builder.Build()`.

    Args:
        builder: the builder holding `sensed`.
        meshcat: the scene's Meshcat.
        geometry: the KOS.
        sensed: the sensed bundle's output port (33).
        publish_period_s: update period [s]: the scene's (scenario.visualization).
        goal_L: x_goal (2,) in L, drawn as a small sphere.
        height_m: height of the drawn zones [m].
        name: the system's name in the diagram.
        prefix: Meshcat path prefix, as the scene's.

    Returns:
        The PlanarKeepOutScene.
    """
    system = builder.AddNamedSystem(
        name,
        PlanarKeepOutScene(meshcat, geometry, publish_period_s, height_m=height_m, prefix=prefix),
    )
    builder.Connect(sensed, system.GetInputPort(SENSED_PORT))
    meshcat.Delete(f"{prefix}/planar_plan")
    if goal_L is not None:
        goal = np.asarray(goal_L, float)
        radius = 0.05 * geometry.chaser_side_m
        meshcat.SetObject(f"{prefix}/planar_plan/goal", Sphere(radius), GOAL_RGBA)
        meshcat.SetTransform(f"{prefix}/planar_plan/goal", RigidTransform([*goal, 0.0]))
    return system
