"""The chaser in the target body frame, from a run's logged attitudes (numpy only).

Owns: `chaser_in_target_frame` (p_TC_T = R_IT^T R_IL p_LC_L over a whole log, one vectorised
quaternion rotation per array instead of 2 N pydrake calls) and the rotation it is made of.
Read by the generic figures (rpod.diagrams.plots, which re-exports it in its kit) and by a
plug-in's metrics (the LOS corridor's range in T), which must not import matplotlib.
Does not own: frames and rotations in general (rpod.models.frames, the natural home of this
law once that module's current rework has landed).

Quaternions are (w, x, y, z) and normalised first; a zero or non-finite one gives NaN rows. The
test checks the result against pydrake's RotationMatrix (tests/diagrams/test_plots.py).
"""

import numpy as np


def _rotate(q_wxyz: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(q) v for rows of quaternions (..., 4) (w, x, y, z; normalised here) and vectors (..., 3).

    v' = v + 2 w (u x v) + 2 u x (u x v), u the vector part of the unit quaternion.
    """
    q = np.asarray(q_wxyz, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        norm = np.linalg.norm(q, axis=-1, keepdims=True)
        q = np.where((norm > 0.0) & np.isfinite(norm), q / norm, np.nan)
    w = q[..., :1]
    u = q[..., 1:]
    uv = np.cross(u, v)
    return v + 2.0 * w * uv + 2.0 * np.cross(u, uv)


def chaser_in_target_frame(q_IT: np.ndarray, q_IL: np.ndarray, p_LC_L: np.ndarray) -> np.ndarray:
    """p_TC_T = R_IT^T R_IL p_LC_L: the chaser position (from the target's origin) in frame T.

    The LVLH origin is the target's centre of mass, so the point is the same and only the frame
    changes. Vectorised over a leading time axis; single samples work too.

    Args:
        q_IT: Target attitude in I, (w, x, y, z), shape (N, 4) or (4,); need not be unit.
        q_IL: LVLH attitude in I, (w, x, y, z), shape (N, 4) or (4,); need not be unit.
        p_LC_L: Chaser position in L [m], shape (N, 3) or (3,).

    Returns:
        p_TC_T [m], shape (N, 3) (or (3,) for single samples). Rows whose quaternion has zero or
        non-finite norm are NaN.
    """
    q_IT = np.asarray(q_IT, dtype=float)
    p_TC_I = _rotate(q_IL, np.asarray(p_LC_L, dtype=float))
    q_TI = q_IT * np.array([1.0, -1.0, -1.0, -1.0])  # conjugate: R_TI = R_IT^T
    return _rotate(q_TI, p_TC_I)
