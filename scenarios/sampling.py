"""Distributions of a campaign's `sample:` block, and the passively safe relative-orbit sampler.

Owns: parsing and checking a distribution given as plain YAML data (`{dist: uniform, low: 1,
high: 2}`), drawing from it with a numpy `Generator`, and the named sampler of passively safe
relative orbits (paper 000 eqs. 6-7) that sets `chaser.p_LC_L` and `chaser.v_LC_L` together
(optionally redrawn until the start range is within bounds, and with the chaser's initial
attitude `chaser.rpy_LC_deg` on the line of sight).
Does not own: which scenario field a draw goes to, seeds, or run ids (campaign.py).

Distributions (every parameter may be a number, or a list for a vector draw of that length):

    {dist: uniform, low: a, high: b}          a < b
    {dist: normal, mean: m, std: s}           s >= 0
    {dist: log_uniform, low: a, high: b}      0 < a < b; log(x) is uniform
    {dist: choice, values: [...], weights: [...]}   weights optional, >= 0, not all 0
    {dist: direction, scale: r}               a uniform unit vector in R^3 times r; r is a number
                                              or a scalar distribution (e.g. a tumble rate)
    {dist: attitude}                          a uniform rotation (Haar measure on SO(3)) as a
                                              quaternion (w, x, y, z) with w >= 0

A `Distribution.draw(rng)` returns plain Python data (float, list of floats, or a `choice`
value as written), so that what a campaign sends to a worker and stores is plain data.
Problems are `ScenarioError(location, message)`; the caller adds the file name.
"""

import dataclasses
import math

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix

from rpod.diagrams.scenario import ScenarioError
from rpod.models.cw import passively_safe_state
from rpod.planners.pointing import min_rotation
from rpod.scenarios.schema import quote

DISTRIBUTIONS = ("uniform", "normal", "log_uniform", "choice", "direction", "attitude")

_PARAMETERS = {
    "uniform": ("low", "high"),
    "normal": ("mean", "std"),
    "log_uniform": ("low", "high"),
    "choice": ("values", "weights"),
    "direction": ("scale",),
    "attitude": (),
}


def _plain(value):
    """numpy scalars and arrays -> Python floats and lists (JSON- and YAML-friendly)."""
    array = np.asarray(value, dtype=float)
    return float(array) if array.ndim == 0 else array.tolist()


def _numbers(value, location: str) -> np.ndarray:
    """A finite number or a non-empty flat list of finite numbers, as a float array."""
    is_number = isinstance(value, (int, float)) and not isinstance(value, bool)
    is_list = (
        isinstance(value, list)
        and value
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    )
    if not (is_number or is_list):
        raise ScenarioError(location, f"expected a number or a list of numbers, got {quote(value)}")
    try:
        array = np.asarray(value, dtype=float)
    except OverflowError:  # an integer beyond the floats
        raise ScenarioError(location, f"must be finite, got {quote(value)}") from None
    if not np.all(np.isfinite(array)):
        raise ScenarioError(location, f"must be finite, got {quote(value)}")
    return array


@dataclasses.dataclass(frozen=True)
class Distribution:
    """One parsed, checked distribution; `draw(rng)` samples it."""

    kind: str
    parameters: dict

    def draw(self, rng: np.random.Generator):
        p = self.parameters
        if self.kind == "uniform":
            return _plain(rng.uniform(p["low"], p["high"]))
        if self.kind == "normal":
            return _plain(rng.normal(p["mean"], p["std"]))
        if self.kind == "log_uniform":
            return _plain(np.exp(rng.uniform(np.log(p["low"]), np.log(p["high"]))))
        if self.kind == "choice":
            index = rng.choice(len(p["values"]), p=p["weights"])
            return p["values"][int(index)]
        if self.kind == "direction":
            scale = p["scale"]
            magnitude = scale.draw(rng) if isinstance(scale, Distribution) else scale
            # An isotropic Gaussian normalised is uniform on the sphere (Muller 1959).
            while True:
                vector = rng.standard_normal(3)
                norm = float(np.linalg.norm(vector))
                if norm > 1e-12:
                    return (magnitude * vector / norm).tolist()
        if self.kind == "attitude":
            # A normalised 4-D Gaussian is uniform on S^3, i.e. Haar-uniform on SO(3)
            # (Shoemake, Graphics Gems III); w >= 0 picks one of the two equal quaternions.
            while True:
                q = rng.standard_normal(4)
                norm = float(np.linalg.norm(q))
                if norm > 1e-12:
                    q = q / norm
                    return (q if q[0] >= 0.0 else -q).tolist()
        raise AssertionError(self.kind)  # parse_distribution admits only DISTRIBUTIONS

    @property
    def scalar(self) -> bool:
        """True when every draw is a single number."""
        if self.kind in ("uniform", "normal", "log_uniform"):
            return all(np.ndim(v) == 0 for v in self.parameters.values())
        if self.kind == "choice":
            return all(
                isinstance(v, (int, float)) and not isinstance(v, bool)
                for v in self.parameters["values"]
            )
        return False


def _same_length(arrays: dict, location: str) -> None:
    sizes = {name: a.size for name, a in arrays.items() if a.ndim == 1}
    if len(set(sizes.values())) > 1:
        raise ScenarioError(location, f"vector parameters differ in length: {sizes}")


def parse_distribution(data, location: str) -> Distribution:
    """Checks plain YAML data describing a distribution; `location` prefixes every error."""
    if not isinstance(data, dict) or "dist" not in data:
        raise ScenarioError(
            location, f"expected a mapping with 'dist: <one of {', '.join(DISTRIBUTIONS)}>'"
        )
    kind = data["dist"]
    if kind not in DISTRIBUTIONS:
        raise ScenarioError(
            f"{location}.dist",
            f"unknown distribution {quote(kind)} (known: {', '.join(DISTRIBUTIONS)})",
        )
    allowed = _PARAMETERS[kind]
    for key in data:
        if key != "dist" and key not in allowed:
            raise ScenarioError(
                f"{location}.{key}",
                f"unknown parameter of {kind} (known: {', '.join(allowed) or 'none'})",
            )
    required = {
        "uniform": allowed,
        "normal": allowed,
        "log_uniform": allowed,
        "choice": ("values",),
        "direction": (),
        "attitude": (),
    }[kind]
    for key in required:
        if key not in data:
            raise ScenarioError(
                f"{location}.{key}", f"missing (a {kind} needs {', '.join(required)})"
            )

    if kind in ("uniform", "log_uniform"):
        low = _numbers(data["low"], f"{location}.low")
        high = _numbers(data["high"], f"{location}.high")
        _same_length({"low": low, "high": high}, location)
        if not np.all(high > low):
            raise ScenarioError(
                f"{location}.high", f"must be greater than low ({quote(data['low'])})"
            )
        if kind == "log_uniform" and not np.all(low > 0.0):
            raise ScenarioError(
                f"{location}.low", f"must be positive for log_uniform, got {quote(data['low'])}"
            )
        with np.errstate(over="ignore"):
            if kind == "uniform" and not np.all(np.isfinite(high - low)):
                raise ScenarioError(f"{location}.high", "high - low must be a finite number")
        return Distribution(kind, {"low": low, "high": high})
    if kind == "normal":
        mean = _numbers(data["mean"], f"{location}.mean")
        std = _numbers(data["std"], f"{location}.std")
        _same_length({"mean": mean, "std": std}, location)
        if not np.all(std >= 0.0):
            raise ScenarioError(
                f"{location}.std", f"must not be negative, got {quote(data['std'])}"
            )
        return Distribution(kind, {"mean": mean, "std": std})
    if kind == "choice":
        values = data["values"]
        if not isinstance(values, list) or not values:
            raise ScenarioError(
                f"{location}.values", f"expected a non-empty list, got {quote(values)}"
            )
        weights = None
        if "weights" in data:
            weights = _numbers(data["weights"], f"{location}.weights")
            if weights.shape != (len(values),):
                raise ScenarioError(
                    f"{location}.weights", f"expected {len(values)} weights, one per value"
                )
            with np.errstate(over="ignore"):
                total = weights.sum()
            if np.any(weights < 0.0) or not 0.0 < total < np.inf:
                raise ScenarioError(
                    f"{location}.weights", "must be non-negative, not all zero, with a finite sum"
                )
            weights = weights / total
        return Distribution(kind, {"values": values, "weights": weights})
    if kind == "direction":
        scale = data.get("scale", 1.0)
        if isinstance(scale, dict):
            scale = parse_distribution(scale, f"{location}.scale")
            if not scale.scalar:
                raise ScenarioError(f"{location}.scale", "must be a scalar distribution")
        else:
            value = _numbers(scale, f"{location}.scale")
            if value.ndim != 0:
                raise ScenarioError(
                    f"{location}.scale",
                    f"expected a number or a scalar distribution, got {quote(scale)}",
                )
            scale = float(value)
        return Distribution(kind, {"scale": scale})
    return Distribution(kind, {})  # attitude


def parse_scalar(data, location: str, default=None):
    """A number, or a scalar distribution; `default` (a number) when data is None."""
    if data is None:
        data = default
    if isinstance(data, dict):
        distribution = parse_distribution(data, location)
        if not distribution.scalar:
            raise ScenarioError(location, "must be a scalar distribution")
        return distribution
    value = _numbers(data, location)
    if value.ndim != 0:
        raise ScenarioError(
            location, f"expected a number or a scalar distribution, got {quote(data)}"
        )
    return float(value)


def draw_scalar(value, rng: np.random.Generator) -> float:
    """A number as is, or one draw of a scalar distribution."""
    return float(value.draw(rng)) if isinstance(value, Distribution) else float(value)


# ---------------------------------------------------------------------------------------------
# Passively safe relative orbits (paper 000 Sec. III, eqs. 6-7).

PASSIVELY_SAFE_FIELDS = ("chaser.p_LC_L", "chaser.v_LC_L")
POINTING_FIELD = "chaser.rpy_LC_deg"
_PASSIVELY_SAFE_KEYS = ("radial_m", "cross_track_m", "phase_deg", "cross_track_phase_deg")
_PASSIVELY_SAFE_OPTIONS = ("start_range_m", "point_at_target")
# Redraws of one sample before `start_range_m` is declared unreachable (the acceptance rate of a
# sensible campaign is far above 1e-3, so a correct one never gets here).
MAX_START_RANGE_ATTEMPTS = 1000


@dataclasses.dataclass(frozen=True)
class PassivelySafeSampler:
    """Draws a chaser state on a bounded, drift-free CW relative orbit about the target.

    The radial motion x(t) = x0 cos(nt) + (vx0/n) sin(nt) has the amplitude A0 of paper 000
    eq. 7 (corrected as in rpod.models.cw.safe_ellipse_semi_axes); the sampler draws A0, the
    cross-track amplitude B0 and the two phases, sets
        x0 = A0 cos(phase),  vx0 = n A0 sin(phase),  z0 = B0 cos(phase_z),  vz0 = n B0 sin(phase_z),
    and eq. 6 (rpod.models.cw.passively_safe_state) fixes y0 = 2 vx0 / n and vy0 = -2 n x0, so
    the ellipse has semi-axes (A0, 2 A0, B0) and is centred on the target.

    Each of the four is a number or a scalar distribution (YAML keys radial_m, cross_track_m,
    phase_deg, cross_track_phase_deg); the phases default to uniform on [0, 360) deg.

    Options: `start_range_m: {low, high}` redraws (rejection sampling) until the start distance
    |p_LC_L| = sqrt(A0^2 cos^2 phase + 4 A0^2 sin^2 phase + B0^2 cos^2 phase_z), which does not
    depend on n, is in [low, high]; `point_at_target: true` also sets chaser.rpy_LC_deg so that
    the capture axis (the direction of chaser.capture_point_C) points at the target.
    """

    radial_m: object
    cross_track_m: object
    phase_deg: object
    cross_track_phase_deg: object
    start_range_m: tuple | None = None  # (low, high) [m], or None for no rejection
    point_at_target: bool = False
    location: str = "passively_safe"  # of the YAML block, for errors raised while drawing

    @property
    def fields(self) -> tuple:
        """The scenario fields this sampler sets."""
        return PASSIVELY_SAFE_FIELDS + ((POINTING_FIELD,) if self.point_at_target else ())

    def draw(self, rng_for) -> dict:
        """The draw as plain data; `rng_for(name)` gives the Generator of each parameter.

        Each parameter's Generator is made once and drawn from in sequence, so attempt k of a
        rejected draw is deterministic, and without start_range_m (or when the first attempt is
        accepted) the draw is the same as a single draw. The returned dict is the accepted draw,
        plus `attempts` (1 when the first was accepted).
        """
        rngs = {name: rng_for(name) for name in _PASSIVELY_SAFE_KEYS}
        attempts = 1 if self.start_range_m is None else MAX_START_RANGE_ATTEMPTS
        for attempt in range(1, attempts + 1):
            draw = {name: draw_scalar(getattr(self, name), rngs[name]) for name in rngs}
            if self.start_range_m is None:
                return {**draw, "attempts": attempt}
            low, high = self.start_range_m
            if low <= start_range(draw) <= high:
                return {**draw, "attempts": attempt}
        raise ScenarioError(
            f"{self.location}.start_range_m",
            f"no draw with a start range in [{low:g}, {high:g}] m in {attempts} attempts: "
            "the amplitudes and phases rarely or never give such a distance",
        )


def start_range(draw: dict) -> float:
    """|p_LC_L| of a passively safe draw [m] (the same for every mean motion, so n = 1)."""
    return float(np.linalg.norm(passively_safe_overrides(draw, 1.0)["chaser.p_LC_L"]))


def _bounds(value) -> tuple[float, float]:
    """The smallest and largest value a number or a (non-normal) scalar distribution gives."""
    if not isinstance(value, Distribution):
        return value, value
    if value.kind == "choice":
        return min(value.parameters["values"]), max(value.parameters["values"])
    return float(value.parameters["low"]), float(value.parameters["high"])


def _parse_start_range(data, location: str) -> tuple[float, float]:
    if not isinstance(data, dict):
        raise ScenarioError(location, f"expected a mapping {{low: m, high: m}}, got {quote(data)}")
    for key in data:
        if key not in ("low", "high"):
            raise ScenarioError(f"{location}.{key}", "unknown key (known: low, high)")
    values = {}
    for key in ("low", "high"):
        if key not in data:
            raise ScenarioError(f"{location}.{key}", "missing (start_range_m needs low and high)")
        value = _numbers(data[key], f"{location}.{key}")
        if value.ndim != 0:
            raise ScenarioError(f"{location}.{key}", f"expected a number, got {quote(data[key])}")
        values[key] = float(value)
    if values["low"] < 0.0:
        raise ScenarioError(f"{location}.low", f"must not be negative, got {quote(data['low'])}")
    if not values["high"] > values["low"]:
        raise ScenarioError(f"{location}.high", f"must be greater than low ({quote(data['low'])})")
    return values["low"], values["high"]


def parse_passively_safe(data, location: str) -> PassivelySafeSampler:
    """Checks the `passively_safe:` mapping of a campaign's sample block."""
    known = _PASSIVELY_SAFE_KEYS + _PASSIVELY_SAFE_OPTIONS
    if not isinstance(data, dict):
        raise ScenarioError(location, f"expected a mapping of {', '.join(known)}")
    for key in data:
        if key not in known:
            raise ScenarioError(
                f"{location}.{key}", f"unknown parameter (known: {', '.join(known)})"
            )
    if "radial_m" not in data:
        raise ScenarioError(f"{location}.radial_m", "missing (the radial semi-axis A0)")
    full_turn = {"dist": "uniform", "low": 0.0, "high": 360.0}
    sampler = PassivelySafeSampler(
        radial_m=parse_scalar(data.get("radial_m"), f"{location}.radial_m"),
        cross_track_m=parse_scalar(data.get("cross_track_m"), f"{location}.cross_track_m", 0.0),
        phase_deg=parse_scalar(data.get("phase_deg"), f"{location}.phase_deg", full_turn),
        cross_track_phase_deg=parse_scalar(
            data.get("cross_track_phase_deg"), f"{location}.cross_track_phase_deg", full_turn
        ),
        location=location,
    )
    for name in ("radial_m", "cross_track_m"):
        value = getattr(sampler, name)
        if isinstance(value, Distribution):
            if value.kind == "normal":
                raise ScenarioError(
                    f"{location}.{name}",
                    "an amplitude needs a distribution "
                    "that stays non-negative (uniform, log_uniform or choice)",
                )
            smallest = (
                min(value.parameters["values"])
                if value.kind == "choice"
                else (float(value.parameters["low"]))
            )
        else:
            smallest = value
        if smallest < 0.0:
            raise ScenarioError(f"{location}.{name}", "an amplitude must not be negative")
    if "point_at_target" in data:
        if not isinstance(data["point_at_target"], bool):
            raise ScenarioError(
                f"{location}.point_at_target",
                f"expected true or false, got {quote(data['point_at_target'])}",
            )
        sampler = dataclasses.replace(sampler, point_at_target=data["point_at_target"])
    if "start_range_m" in data:
        low, high = _parse_start_range(data["start_range_m"], f"{location}.start_range_m")
        # Whatever the phases, A0 <= |p_LC_L| <= sqrt(4 A0^2 + B0^2).
        (a_min, a_max), (_, b_max) = _bounds(sampler.radial_m), _bounds(sampler.cross_track_m)
        reach = math.hypot(2.0 * a_max, b_max)  # no overflow for huge amplitudes
        if high < a_min or low > reach:
            raise ScenarioError(
                f"{location}.start_range_m",
                f"[{low:g}, {high:g}] m can never be met: radial_m and cross_track_m put the "
                f"start between {a_min:g} and {reach:g} m from the target",
            )
        sampler = dataclasses.replace(sampler, start_range_m=(low, high))
    return sampler


def passively_safe_overrides(draw: dict, n: float, capture_point_C=None) -> dict:
    """chaser.p_LC_L and chaser.v_LC_L of a passively safe draw for mean motion n.

    With `capture_point_C` (the chaser's, in C), also chaser.rpy_LC_deg: the least rotation
    R_LC that carries the capture axis c = capture_point_C / |capture_point_C| (as at the
    identity attitude) onto the line of sight -p_LC_L / |p_LC_L| (a half turn about an axis
    normal to c when they are antiparallel; rpod.planners.pointing.min_rotation), i.e. the
    attitude the pointing law of paper 000 Sec. IV starts from.
    """
    phase = math.radians(draw["phase_deg"])
    phase_z = math.radians(draw["cross_track_phase_deg"])
    A0, B0 = draw["radial_m"], draw["cross_track_m"]
    state = passively_safe_state(  # paper 000 eq. 6
        n,
        x=A0 * math.cos(phase),
        vx=n * A0 * math.sin(phase),
        z=B0 * math.cos(phase_z),
        vz=n * B0 * math.sin(phase_z),
    )
    overrides = {"chaser.p_LC_L": state[:3].tolist(), "chaser.v_LC_L": state[3:].tolist()}
    if capture_point_C is not None:
        overrides[POINTING_FIELD] = pointing_rpy_deg(state[:3], capture_point_C)
    return overrides


def pointing_rpy_deg(p_LC_L, capture_point_C) -> list[float]:
    """Roll-pitch-yaw [deg] of the least rotation putting the capture axis on the line of sight."""
    p = np.asarray(p_LC_L, dtype=float)
    c = np.asarray(capture_point_C, dtype=float)
    range_m, length = float(np.linalg.norm(p)), float(np.linalg.norm(c))
    if range_m < 1e-9:
        raise ScenarioError(
            "chaser.p_LC_L", "the start is at the target: no line of sight for point_at_target"
        )
    if length < 1e-9:
        raise ScenarioError(
            "chaser.capture_point_C",
            "is at the centre of mass: no capture axis for point_at_target to point",
        )
    R_LC = min_rotation(c / length, -p / range_m)
    return np.degrees(RollPitchYaw(RotationMatrix(R_LC)).vector()).tolist()
