"""The estimated target in the recording: a translucent copy where the navigation puts it.

Owns: `EstimatedTargetGhost`, a scene system that draws the target's shape at the pose the
controller believes (the navigation's `sensed` output), beside the true target that
`RendezvousScene` draws. Published by the diagram's SceneDriver like every scene system.
Does not own: the scene itself (rpod.systems.scene), the estimate (rpod.systems.navigation).

Where it stands: the scene is drawn in L with the true target at the origin and the chaser at
its true p_LC_L; the navigation believes the target at -p_LC_L_est from the chaser, so the
ghost stands at p_LC_L - p_LC_L_est, turned by R_LT = R_IL_est^T R_IT_est. A perfect estimate
hides the ghost inside the target; its offset is the estimate's error, drawn to scale.
"""

from __future__ import annotations

import numpy as np
from pydrake.geometry import Meshcat, Rgba
from pydrake.math import RigidTransform, RotationMatrix

from rpod.models.frames import rotation_from_wxyz
from rpod.systems.lifetime import LeafSystem
from rpod.systems.scene import SceneGeometry, body_shape
from rpod.systems.sensed import SENSED_SIZE, Sensed

GHOST_RGBA = Rgba(0.55, 0.20, 0.85, 0.35)
"""Violet, translucent: not the target's colour, and the true body shows through."""


class EstimatedTargetGhost(LeafSystem):
    """Draws the target where the estimate puts it (module docstring).

    Input ports:
        truth_sensed (33): the true bundle (the chaser's true position in the scene).
        estimated_sensed (33): what the controller reads (the navigation's output).
    """

    def __init__(
        self,
        meshcat: Meshcat,
        geometry: SceneGeometry,
        publish_period_s: float,
        prefix: str = "rpod",
    ):
        super().__init__()
        self._meshcat = meshcat
        self._geometry = geometry
        self._path = f"{prefix}/overlay/estimated_target"
        self._truth_port = self.DeclareVectorInputPort("truth_sensed", SENSED_SIZE)
        self._estimate_port = self.DeclareVectorInputPort("estimated_sensed", SENSED_SIZE)
        self.scene_publish_period_s = publish_period_s
        self._last_publish_time = -np.inf
        self.DeclareInitializationPublishEvent(self._initialize)

    def pose(self, context) -> RigidTransform | None:
        """X_LG, the ghost's pose in the scene (None before the estimate exists)."""
        truth = Sensed.from_vector(self._truth_port.Eval(context))
        estimate = Sensed.from_vector(self._estimate_port.Eval(context))
        if not np.all(np.isfinite(estimate.vector[:24])):
            return None
        R_LT = rotation_from_wxyz(estimate.q_IL).T @ rotation_from_wxyz(estimate.q_IT)
        return RigidTransform(RotationMatrix(R_LT), truth.p_LC_L - estimate.p_LC_L)

    def _initialize(self, context) -> None:
        geometry = self._geometry
        shape = body_shape(
            "estimated_target", geometry.target_box_size_m, geometry.target_vertices_T
        )
        self._meshcat.SetObject(self._path, shape, GHOST_RGBA)
        self._last_publish_time = -np.inf
        self.PublishScene(context)

    def PublishScene(self, context) -> None:
        """Moves the ghost to the estimate's pose at this time (once per time)."""
        t = context.get_time()
        if t <= self._last_publish_time:
            return
        self._last_publish_time = t
        X = self.pose(context)
        self._meshcat.SetProperty(self._path, "visible", X is not None, time_in_recording=t)
        if X is not None:
            self._meshcat.SetTransform(self._path, X, time_in_recording=t)
