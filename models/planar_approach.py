"""Paper 003's planar approach: rigid-body dynamics, the spinning target's docking face and the
dynamic keep-out zone (KOS), as plain functions and one geometry dataclass.

Owns: eqs. 1-2 (`planar_derivative`) and their forward-Euler step eq. 7 (`euler_step`), the
exact zero-order-hold step that checkers re-integrate with (`zoh_step`), r_safe of eq. 10, the
target attitude and docking normal, the chaser's final attitude (hard constraint 6), the goal
point, the chaser's heading from facing the docking face (`face_heading_error`), the KOS of
Sec. III-C with its State I / State II switching (`KeepOutGeometry`) in three forms (the exact
signed distance-like q of eq. 9, smooth terms for an NLP, circumscribing polygons for
sequential convex programming), the overlap test of the true squares (`squares_gap`), and the
body-frame wrench limits of the planar_8 thrusters (`planar_8_wrench_limits`,
`body_wrench_excess`).
Does not own: any optimisation (rpod.planners.planar_approach), time or Drake systems.

Scalar types: `planar_derivative`, `euler_step`, `to_target_frame`, `body_wrench` and
`keepout_smooth_terms` use only +, -, *, / and pydrake.math functions, so they take float
arrays, AutoDiffXd object arrays and symbolic Expression object arrays alike. The rest is
float numpy (vectorised over points).

Conventions (the paper is silent; chosen here):
- World frame W = paper 003's inertial frame, target centre at the origin, angles about +z.
- Target attitude theta_t(t) = theta_t0 + omega_target t. Its docking face is the face whose
  outward normal is the target body's +x axis: n(t) = [cos theta_t, sin theta_t].
- Target frame T: x_T along n, y_T along the docking face (p_T = R(theta_t)^T p).
- theta_approach (Sec. V-A: 3 pi/4) is the target attitude at closest approach (the final time).
- The chaser's docking face is its body +x face. Hard constraint 6 puts it against the target's
  docking face: the chaser's +x axis points along -n(t_f), theta_finish = theta_approach + pi,
  taken as the 2 pi-equivalent nearest to the chaser's initial attitude (the shortest turn).
- Goal (eq. 5): x_goal = d_goal n(t_f), on the docking normal at the standoff d_goal. Default
  d_goal = r_relaxed + l_margin = l_t/2 + l_s/2 + 2 l_margin (0.36 m for two 0.3 m squares):
  the chaser's docking face 2 l_margin (6 cm) from the target's, in the manipulator's reach.

Keep-out geometry (Sec. III-C, Fig. 3; with Zappulla et al.'s docking KOS as the paper says; the
figure is not in the text, so the placement below is a choice, tested in
tests/models/test_planar_approach.py). In T, with H = (l_s + l_t) / 2 (face-to-face contact
distance of the centres) and l_margin = 0.1 l_s:
- State I (general approach): the disc |p| < r_safe (eq. 10) and two half-ellipses E+ and E-.
  Each half-ellipse has its flat side on the line x_T = 0 (through the target centre, parallel
  to the docking face) and bulges towards the docking side: semi-axes r_safe along the docking
  normal and r_safe / 2 along the face, centred at y_T = +-(r_safe / 2 + l_margin). They flank
  the docking corridor: the corridor between them is 2 l_margin wide at x_T = 0 and widens
  outward (+-0.12 m at the default goal); beyond the disc they stand out as two "wings" (out to
  0.54 m from the centre for two 0.3 m squares) that make the chaser enter the corridor from
  the front instead of sliding in from the side.
- State II (final approach): the disc is relaxed on the docking side (x_T > 0) to radius
  r_relaxed = H + l_margin (face-to-face contact plus the margin); the rear half-disc of radius
  r_safe and the two half-ellipses stay.
- Switching (memoryless, from the chaser's current relative pose, as the paper's "state"):
  State II iff |p| < 1.5 r_safe, the bearing of p from the docking normal is below the angle
  threshold alpha, and (when the chaser's heading is given) the chaser is aligned with the
  docking face: |wrap(theta_c - theta_t - pi)| <= `alignment_tolerance_rad` (3 deg); otherwise
  State I. The paper's text defines State II as "close to and properly aligned with the target"
  and relaxes the zone because "in State II, the chaser is aligned with the target's docking
  surface" (Sec. III-C), but its two thresholds are on the position only; without the heading
  condition a chaser still turned tens of degrees off the face may enter the relaxed zone and
  its square overlaps the target's (Sec. V-A's position-only plan did, 77-84 s). rpod makes the
  alignment part of the switch (`face_heading_error`); `state(p_T)` and `q(p_T)` without a
  heading are the position-only switching.
- alignment_tolerance_rad: the chaser's square turned by delta from aligned reaches
  h (cos delta + sin delta) instead of h along each target axis; sampling the allowed State II
  region (tests/models/test_planar_approach.py), two 0.3 m squares keep a gap of 16 mm aligned,
  8.7 mm at 3 deg, 1.5 mm at 6 deg and touch from ~7 deg. 3 deg leaves half the aligned gap.
- alpha: an aligned chaser (at its final attitude, faces parallel) moving radially inwards
  along a bearing phi first touches the target at lateral offset H tan(phi): face on face while
  H tan(phi) < H, corner to corner at phi = pi / 4 (the diagonal of eq. 10's worst case).
  Keeping l_margin of face overlap, alpha = atan((H - l_margin) / H) (41.99 deg for two 0.3 m
  squares).
- With these numbers an aligned chaser whose centre is outside the State II zone never overlaps
  the target (the half-ellipses cover the corners of the box |x_T|, |y_T| < H outside the
  relaxed disc), and inside r_safe the corridor between the half-ellipses is narrower than the
  angle threshold, so a chaser inside r_safe in State II cannot leave State II sideways.

q, the signed distance-like function of eq. 9 (q >= 0 outside, q < 0 inside, in m): for a disc
|p| - r (State II's: r = r_relaxed where x_T > 0, r_safe elsewhere, so the seam x_T = 0 between
its two halves counts as inside); for a half-ellipse max(q_ellipse, -x_T) (outside if outside
the ellipse or behind its flat side), with q_ellipse = (sqrt(e) - 1) b and e the ellipse's
normalised quadratic form (the exact sign, not the Euclidean distance); for a union of
forbidden pieces the minimum.
"""

import dataclasses
import math

import numpy as np
import pydrake.math as dm

from rpod.models.thrusters import planar_8, wrench_matrix

STATE_I = 1
"""General approach: the full disc of radius r_safe plus the two half-ellipses."""
STATE_II = 2
"""Final approach: the docking-side half-disc relaxed to r_relaxed."""

SWITCH_DISTANCE_FACTOR = 1.5
"""The switching distance threshold, in units of r_safe (Sec. III-C)."""

MARGIN_FRACTION = 0.1
"""l_margin as a fraction of the chaser's side l_s (eq. 10)."""

ALIGNMENT_TOLERANCE_RAD = math.radians(3.0)
"""Default heading tolerance of State II (module docstring: "alignment_tolerance_rad")."""


# ----------------------------------------------------------------------------------- dynamics


def planar_derivative(x, F, mass_kg: float, inertia_kg_m2: float):
    """x_dot of eq. 2 for x = [x, y, theta, v_x, v_y, omega] and F = [F_x, F_y, tau] in W.

    Scalar-generic (float, AutoDiffXd, Expression object arrays).
    """
    return np.array([x[3], x[4], x[5], F[0] / mass_kg, F[1] / mass_kg, F[2] / inertia_kg_m2])


def euler_step(x, F, dt_s: float, mass_kg: float, inertia_kg_m2: float):
    """x_k+1 = x_k + f(x_k, F_k) dt, the forward-Euler map of eq. 7 (scalar-generic)."""
    return np.asarray(x) + planar_derivative(x, F, mass_kg, inertia_kg_m2) * dt_s


def zoh_step(x, F, dt_s: float, mass_kg: float, inertia_kg_m2: float) -> np.ndarray:
    """The exact solution of eq. 2 after dt under a constant world wrench F (float).

    Position and attitude gain the dt^2 / 2 acceleration term that eq. 7 drops.
    """
    x = np.asarray(x, dtype=float)
    F = np.asarray(F, dtype=float)
    a = np.array([F[0] / mass_kg, F[1] / mass_kg, F[2] / inertia_kg_m2])
    out = np.empty(6)
    out[:3] = x[:3] + x[3:] * dt_s + 0.5 * a * dt_s**2
    out[3:] = x[3:] + a * dt_s
    return out


# ------------------------------------------------------------------------- target and goal


def r_safe(chaser_side_m: float, target_side_m: float) -> float:
    """Eq. 10: sqrt(2)/2 l_s + sqrt(2)/2 l_t + l_margin, l_margin = 10 % of l_s."""
    half_diagonals = 0.5 * math.sqrt(2.0) * (chaser_side_m + target_side_m)
    return half_diagonals + MARGIN_FRACTION * chaser_side_m


def target_attitude(t_s, theta_target0_rad: float, omega_target_rad_s: float):
    """theta_t(t) = theta_t0 + omega_target t (the target spins about its fixed centre)."""
    return theta_target0_rad + omega_target_rad_s * np.asarray(t_s, dtype=float)


def docking_normal(theta_target_rad) -> np.ndarray:
    """Outward normal of the target's docking face in W, [cos theta_t, sin theta_t] (.., 2)."""
    theta = np.asarray(theta_target_rad, dtype=float)
    return np.stack([np.cos(theta), np.sin(theta)], axis=-1)


def wrap_to_pi(angle):
    """Angle(s) wrapped to [-pi, pi)."""
    return (np.asarray(angle, dtype=float) + math.pi) % (2.0 * math.pi) - math.pi


def chaser_final_attitude(theta_approach_rad: float, theta_chaser0_rad: float) -> float:
    """theta_finish of eq. 6: the chaser's +x face against the target's docking face.

    theta_approach + pi, shifted by 2 pi k to the value nearest theta_chaser0 (shortest turn).
    """
    face_to_face = theta_approach_rad + math.pi
    return theta_chaser0_rad + float(wrap_to_pi(face_to_face - theta_chaser0_rad))


def face_heading_error(theta_chaser_rad, theta_target_rad):
    """wrap(theta_c - theta_t - pi): the chaser's heading from facing the docking face (..)."""
    return wrap_to_pi(np.asarray(theta_chaser_rad, float) - theta_target_rad - math.pi)


def goal_position(theta_approach_rad: float, standoff_m: float) -> np.ndarray:
    """x_goal of eq. 5: the point at the standoff on the docking normal at arrival (W, m)."""
    return standoff_m * np.array([math.cos(theta_approach_rad), math.sin(theta_approach_rad)])


def to_target_frame(p, theta_target_rad: float):
    """p_T = R(theta_t)^T p: (x_T, y_T) of a world point (scalar-generic in p, theta float)."""
    c, s = math.cos(theta_target_rad), math.sin(theta_target_rad)
    return c * p[0] + s * p[1], -s * p[0] + c * p[1]


def _elementwise(name: str, value):
    """numpy's function on floats and float arrays, pydrake.math's on AutoDiffXd/Expression."""
    if isinstance(value, np.ndarray):
        if value.dtype != object:
            return getattr(np, name)(value)
        return np.array([getattr(dm, name)(v) for v in value.flat], dtype=object).reshape(
            value.shape
        )
    if isinstance(value, (float, int, np.floating)):
        return getattr(np, name)(value)
    return getattr(dm, name)(value)


# --------------------------------------------------------------------------------- keep-out


@dataclasses.dataclass(frozen=True)
class KeepOutGeometry:
    """The KOS of Sec. III-C for a square chaser and a square target (module docstring).

    Attributes:
        chaser_side_m: l_s.
        target_side_m: l_t.
        alignment_tolerance_rad: State II needs the chaser's heading within this of facing the
            docking face (module docstring).
    """

    chaser_side_m: float = 0.3
    target_side_m: float = 0.3
    alignment_tolerance_rad: float = ALIGNMENT_TOLERANCE_RAD

    def __post_init__(self):
        for name in ("chaser_side_m", "target_side_m", "alignment_tolerance_rad"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name}: must be positive, got {value!r}")

    @property
    def margin_m(self) -> float:
        """l_margin = 0.1 l_s (eq. 10)."""
        return MARGIN_FRACTION * self.chaser_side_m

    @property
    def r_safe_m(self) -> float:
        """r_safe of eq. 10."""
        return r_safe(self.chaser_side_m, self.target_side_m)

    @property
    def contact_distance_m(self) -> float:
        """H = (l_s + l_t) / 2: centre distance of the two squares face to face."""
        return 0.5 * (self.chaser_side_m + self.target_side_m)

    @property
    def r_relaxed_m(self) -> float:
        """The State II docking-side radius, H + l_margin."""
        return self.contact_distance_m + self.margin_m

    @property
    def ellipse_semi_axes_m(self) -> tuple[float, float]:
        """(a, b): r_safe along the docking normal, r_safe / 2 along the face."""
        return self.r_safe_m, 0.5 * self.r_safe_m

    @property
    def ellipse_offset_m(self) -> float:
        """|y_T| of the half-ellipses' centres, r_safe / 2 + l_margin."""
        return 0.5 * self.r_safe_m + self.margin_m

    @property
    def switch_distance_m(self) -> float:
        """State II needs |p| below 1.5 r_safe (Sec. III-C)."""
        return SWITCH_DISTANCE_FACTOR * self.r_safe_m

    @property
    def switch_angle_rad(self) -> float:
        """alpha = atan((H - l_margin) / H): the bearing threshold of State II."""
        H = self.contact_distance_m
        return math.atan((H - self.margin_m) / H)

    @property
    def default_goal_standoff_m(self) -> float:
        """r_relaxed + l_margin: faces 2 l_margin apart on the docking normal."""
        return self.r_relaxed_m + self.margin_m

    @property
    def state_i_extent_m(self) -> float:
        """Largest |p| of the State I zone (the half-ellipses' wings reach beyond r_safe)."""
        a, b = self.ellipse_semi_axes_m
        s = np.linspace(-0.5 * math.pi, 0.5 * math.pi, 2001)
        reach = np.hypot(a * np.cos(s), self.ellipse_offset_m + b * np.abs(np.sin(s)))
        return max(self.r_safe_m, float(reach.max()))

    # ---------------------------------------------------------------- exact (float) forms

    def bearing_rad(self, p_T) -> np.ndarray:
        """|angle| between p and the docking normal, from T coordinates (.., 2)."""
        p_T = np.asarray(p_T, dtype=float)
        return np.abs(np.arctan2(p_T[..., 1], p_T[..., 0]))

    def state(self, p_T, heading_error=None) -> np.ndarray:
        """The KOS state (STATE_I or STATE_II) of points given in T (.., 2), memoryless.

        heading_error (..): `face_heading_error` of the chaser at each point; State II then
        also needs |heading_error| <= alignment_tolerance_rad. None: the position-only switch.
        """
        p_T = np.asarray(p_T, dtype=float)
        near = np.hypot(p_T[..., 0], p_T[..., 1]) < self.switch_distance_m
        in_cone = self.bearing_rad(p_T) < self.switch_angle_rad
        region = near & in_cone
        if heading_error is not None:
            error = np.abs(wrap_to_pi(heading_error))
            region = region & (error <= self.alignment_tolerance_rad)
        return np.where(region, STATE_II, STATE_I)

    def _half_ellipse_q(self, x, y, sign: float) -> np.ndarray:
        a, b = self.ellipse_semi_axes_m
        e = (x / a) ** 2 + ((y - sign * self.ellipse_offset_m) / b) ** 2
        return np.maximum((np.sqrt(e) - 1.0) * b, -x)

    def q_state(self, p_T, state: int) -> np.ndarray:
        """q of eq. 9 for the zone of the given state, at points in T (.., 2) [m]."""
        p_T = np.asarray(p_T, dtype=float)
        x, y = p_T[..., 0], p_T[..., 1]
        r = np.hypot(x, y)
        ellipses = np.minimum(self._half_ellipse_q(x, y, 1.0), self._half_ellipse_q(x, y, -1.0))
        if state == STATE_I:
            return np.minimum(r - self.r_safe_m, ellipses)
        if state != STATE_II:
            raise ValueError(f"state must be STATE_I or STATE_II, got {state!r}")
        disc = r - np.where(x > 0.0, self.r_relaxed_m, self.r_safe_m)
        return np.minimum(disc, ellipses)

    def q(self, p_T, heading_error=None) -> np.ndarray:
        """q of eq. 9 in the state the points are in (the switching of `state`) [m]."""
        p_T = np.asarray(p_T, dtype=float)
        state = self.state(p_T, heading_error)
        return np.where(state == STATE_II, self.q_state(p_T, STATE_II), self.q_state(p_T, STATE_I))

    # ------------------------------------------------------------- polygons (convex pieces)

    def pieces(self, state: int, facets_per_half: int = 48) -> list[tuple[np.ndarray, np.ndarray]]:
        """The zone of a state as convex forbidden pieces, each a circumscribing polygon in T.

        Returns a list of (normals (M, 2) unit, offsets (M,)): a point p_T is outside the piece
        iff some facet has normals @ p_T - offsets >= 0, and each facet's half-plane is disjoint
        from the piece's interior, so "facet i >= 0" is a convex restriction of "outside".
        Polygons are circumscribed (tangent lines every pi / facets_per_half of the
        parametrisation), so they contain the exact shapes; they exceed them by at most
        1 / cos(pi / (2 facets_per_half)) - 1 (5e-4 at 48: 0.25 mm on r_safe = 0.45 m).
        """
        m = int(facets_per_half)
        half = np.linspace(-0.5 * math.pi, 0.5 * math.pi, m + 1)
        full = np.linspace(0.0, 2.0 * math.pi, 2 * m, endpoint=False)
        a, b = self.ellipse_semi_axes_m
        pieces = []
        if state == STATE_I:
            pieces.append(_disc_facets(self.r_safe_m, full))
        elif state == STATE_II:
            pieces.append(_disc_facets(self.r_safe_m, half + math.pi, flat_normal=(1.0, 0.0)))
            pieces.append(_disc_facets(self.r_relaxed_m, half, flat_normal=(-1.0, 0.0)))
        else:
            raise ValueError(f"state must be STATE_I or STATE_II, got {state!r}")
        for sign in (1.0, -1.0):
            # Tangent of (a cos s, c + b sin s): cos s x / a + sin s (y - c) / b = 1.
            n = np.stack([np.cos(half) / a, np.sin(half) / b], axis=1)
            norm = np.linalg.norm(n, axis=1)
            offsets = (1.0 + np.sin(half) * sign * self.ellipse_offset_m / b) / norm
            normals = n / norm[:, None]
            normals = np.vstack([normals, [-1.0, 0.0]])  # the flat side x_T = 0
            offsets = np.append(offsets, 0.0)
            pieces.append((normals, offsets))
        return pieces


def _disc_facets(radius, angles, flat_normal=None):
    normals = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    # Circumscribed: tangent lines at the mid-angles would leave gaps at the ends of a half;
    # tangents at the sample angles with the flat side closing the half-disc contain it.
    offsets = np.full(len(angles), float(radius))
    if flat_normal is not None:
        normals = np.vstack([normals, flat_normal])
        offsets = np.append(offsets, 0.0)
    return normals, offsets


def squares_gap(p_T, heading_error, chaser_side_m: float, target_side_m: float) -> np.ndarray:
    """The separating-axis gap of the chaser's and the target's squares [m] (..): > 0 iff they
    do not overlap (a lower bound of their distance; exact overlap test).

    p_T: the chaser centre in T (.., 2); heading_error: `face_heading_error` (..): a square is
    symmetric under quarter turns, so only the heading relative to the target's axes matters.
    The four candidate axes are the two squares' edge normals.
    """
    p_T = np.asarray(p_T, dtype=float)
    phi = np.asarray(heading_error, dtype=float)
    c, s = np.abs(np.cos(phi)), np.abs(np.sin(phi))
    h_c, h_t = 0.5 * chaser_side_m, 0.5 * target_side_m
    reach_c = h_c * (c + s)  # the turned chaser's half-extent along a target axis
    gaps = [np.abs(p_T[..., 0]) - h_t - reach_c, np.abs(p_T[..., 1]) - h_t - reach_c]
    cos_phi, sin_phi = np.cos(phi), np.sin(phi)
    for u in (np.stack([cos_phi, sin_phi], -1), np.stack([-sin_phi, cos_phi], -1)):
        along = np.abs(np.sum(p_T * u, axis=-1))
        gaps.append(along - h_c - h_t * (np.abs(u[..., 0]) + np.abs(u[..., 1])))
    return np.max(gaps, axis=0)


def keepout_smooth_terms(
    p, theta_target_rad: float, geometry: KeepOutGeometry, state: int, sharpness: float = 20.0
) -> list:
    """Smooth terms, each >= 0 iff the point is outside one piece of the state's zone.

    For an NLP with the state fixed per knot (scalar-generic in p; theta_t a float):
    - State I: (|p|^2 / r_safe^2 - 1) and, per half-ellipse, a conservative smooth maximum of
      tanh(e - 1) and tanh(-x_T / b): softmax(u, v) - log(2) / sharpness <= max(u, v), so a term
      >= 0 proves max(e - 1, -x_T) >= 0 (outside the half-ellipse); tanh keeps exp finite.
    - State II (with the switching region as constraints, so x_T > 0 and the half-shapes are
      their full shapes there): (|p|^2 / r_relaxed^2 - 1), (e - 1) per ellipse, the two sides
      of the bearing cone sin(alpha) x_T -+ cos(alpha) y_T, and 1 - |p|^2 / (1.5 r_safe)^2.
    """
    x, y = to_target_frame(p, theta_target_rad)
    a, b = geometry.ellipse_semi_axes_m
    c = geometry.ellipse_offset_m
    rr = x * x + y * y
    terms = []
    if state == STATE_I:
        terms.append(rr / geometry.r_safe_m**2 - 1.0)
        for sign in (1.0, -1.0):
            e = (x / a) * (x / a) + ((y - sign * c) / b) * ((y - sign * c) / b)
            u = _elementwise("tanh", e - 1.0)
            v = _elementwise("tanh", -x / b)
            soft = _elementwise(
                "log", _elementwise("exp", sharpness * u) + _elementwise("exp", sharpness * v)
            )
            soft = soft / sharpness
            terms.append(soft - math.log(2.0) / sharpness)
    elif state == STATE_II:
        terms.append(rr / geometry.r_relaxed_m**2 - 1.0)
        for sign in (1.0, -1.0):
            terms.append((x / a) * (x / a) + ((y - sign * c) / b) * ((y - sign * c) / b) - 1.0)
        alpha = geometry.switch_angle_rad
        terms.append(math.sin(alpha) * x - math.cos(alpha) * y)
        terms.append(math.sin(alpha) * x + math.cos(alpha) * y)
        terms.append(1.0 - rr / geometry.switch_distance_m**2)
    else:
        raise ValueError(f"state must be STATE_I or STATE_II, got {state!r}")
    return terms


# ------------------------------------------------------------------------- wrench limits


def planar_8_wrench_limits(side_m: float, thrust_N: float) -> tuple[float, float]:
    """(max_force_N, max_torque_Nm) per body axis of `planar_8(side_m, thrust_N)`.

    Each is the sum of the positive entries of its row of the wrench matrix (eqs. 3-4): two
    thrusters push along each body axis (2 F_thr), four turn each way (4 (s/2) F_thr).
    """
    B = wrench_matrix(planar_8(side_m=side_m, max_thrust_N=thrust_N))
    rows = B[[3, 4, 2]]  # f_x, f_y, tau_z
    max_fx, max_fy, max_tau = np.clip(rows, 0.0, None).sum(axis=1)
    if not math.isclose(max_fx, max_fy):
        raise AssertionError("planar_8 is symmetric in x and y")
    return float(max_fx), float(max_tau)


def body_wrench(theta_rad, F):
    """[f_bx, f_by, tau]: the world wrench F expressed in the chaser body (eq. 13; generic)."""
    c, s = _elementwise("cos", theta_rad), _elementwise("sin", theta_rad)
    return c * F[0] + s * F[1], -s * F[0] + c * F[1], F[2]


def body_wrench_excess(
    f_body, max_force_N: float, max_torque_Nm: float, coupled: bool = True
) -> np.ndarray:
    """How far body wrenches (.., 3) = [f_bx, f_by, tau] lie outside the limits, in N (<= 0 in).

    The per-axis box |f_bx|, |f_by| <= F_max, |tau| <= tau_max is the limit along each axis
    alone. planar_8 cannot reach the box's corners: its wrench set (a zonotope of the eight
    thrusters, eqs. 3-4) is the box cut by |f_bx| + |f_by| + 2 (F_max / tau_max) |tau| <= 2 F_max
    (each x thruster pair trades f_x for tau, each y pair f_y for tau). coupled=True adds that
    cut; tests check it against the zonotope's hull. Torque excess is converted to N by
    F_max / tau_max.
    """
    w = np.asarray(f_body, dtype=float)
    fx, fy, tau = w[..., 0], w[..., 1], w[..., 2]
    scale = max_force_N / max_torque_Nm
    excess = np.maximum.reduce(
        [np.abs(fx) - max_force_N, np.abs(fy) - max_force_N, (np.abs(tau) - max_torque_Nm) * scale]
    )
    if coupled:
        cut = np.abs(fx) + np.abs(fy) + 2.0 * scale * np.abs(tau) - 2.0 * max_force_N
        excess = np.maximum(excess, cut)
    return excess
