"""Navigation on the `sensed` seam: what the controllers read, the truth or an estimate.

Owns: `RelativeNavigation`, the LeafSystem that samples the sensors from the truth and outputs
the filter's estimate as a `sensed` vector (rpod.systems.sensed), so that no controller
changes, and `NavigationComputer`, its computation tick by tick. The scenario's choices,
`Truth` and `Ekf`, are rpod.systems.navigation_config's.
Does not own: the sensor and filter mathematics (rpod.models.pose_sensor, .chaser_sensors,
.relative_navigation), the truth before t = 0 that the lead-in reads (rpod.diagrams.navigation
integrates it), or the wiring (rpod.diagrams.builder).

What the estimate is made of, at the sensors' samples (events, on a grid of `update_period_s`):
- relative position, velocity, target attitude, rate and inertia parameters: the multiplicative
  EKF (rpod.models.relative_navigation) on the pose sensor's fixes. A fix taken at t arrives
  `latency_s` later (rounded up to the grid), and the filter is updated at the fix's own time.
  The update is computed at the sample and shown from the arrival on (an `EstimateVersion`):
  what a flight computer updating at the arrival would show, since the update uses nothing
  later than the fix, without an event of its own at every arrival. The chaser's thrust enters
  the process model as a known input, the position and velocity increments an IMU's
  accelerometer gives between events (`_thrust_since`); four fixes refused in a row reset the
  part of the filter that diverged (rpod.models.relative_navigation.reset_diverged);
- the chaser's attitude: the last star-tracker fix carried by the gyro's rates (bias not
  estimated: 1 deg/h over the 0.2 s between fixes is 0.2 arcsec, below the tracker's 10); its
  rate: the gyro's mean over `gyro_window_s`;
- the target's orbit: the chaser's GNSS fix less the relative estimate, carried between fixes
  by the truth's gravity model; LVLH (q_IL, w_IL_L) is that orbit's.
Between events the output carries the estimate of the last fix arrived to the instant it is read
(RK4 on the nominal, plus the thrust's increments since the event), so a controller reads the
estimate of that instant, from the fixes that had arrived before it.

The filter starts from measurements only: the sensors run over `lead_in_s` before t = 0, on the
truth integrated backwards from the scenario's start (the chaser coasting; every rpod scenario
starts where guidance takes over from an earlier phase, whose navigation already ran).

Random draws come from (the scenario's seed, the sensor, the tick), so a run is deterministic
and one sensor's draws do not depend on another's (`TickDraws`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from pydrake.common.value import Value

from rpod.models import relative_navigation as rn
from rpod.models.frames import (
    attitude_error,
    cross,
    quaternion_conjugate,
    quaternion_product,
    quaternion_wxyz,
    rotation_vector_quaternion,
    rotations_from_wxyz,
)
from rpod.models.gravity import gravity_acceleration_xyz
from rpod.models.orbit import lvlh_of
from rpod.models.relative_orbit import TargetOrbit
from rpod.systems.lifetime import LeafSystem
from rpod.systems.navigation_config import Ekf, scaled_sensors
from rpod.systems.sensed import SENSED_SIZE, Sensed

ESTIMATE_SIZE = 15
"""The `estimate` port: [p_LC_L, v_LC_L, q_IT, w_IT_T, inertia parameters (p_x, p_y)]."""
STATUS_FIELDS = ("fixes_used", "fixes_rejected", "fixes_unseen", "filter_restarts", "last_nis")
"""The `navigation_status` port, in this order (counts since the lead-in began)."""

NAVIGATION_LOG_KEYS = {
    "estimate": "navigation_estimate",
    "covariance": "navigation_covariance",
    "navigation_status": "navigation_status",
}
"""The log key of each output port (the builder also logs `sensed` as `navigation_sensed`)."""

# The random streams, one per sensor (module docstring).
_POSE, _STAR, _GYRO, _GNSS, _BIAS = range(5)
_TIME_TOLERANCE_S = 1e-9
_ZERO = (0.0, 0.0, 0.0)
_ZERO3 = np.zeros(3)
_OUTPUT_STEP_S = 0.5  # the longest RK4 step of the estimate carried to a read
# The filter's measurement sigma is never below these (1 mm, 0.06 deg). With noise-free fixes
# (noise_scale 0) and floors 100 times smaller, the Euler model's error while the inertia is
# still being learned stood out of the innovation's tiny covariance: the gate refused every fix
# from 4 s on, and the estimate drifted (3 mm in 20 s on hold_point).
_SIGMA_FLOOR_M, _SIGMA_FLOOR_RAD = 1e-3, 1e-3


_BLOCK_TICKS = 256  # ticks whose draws one generator makes at once
_NORMALS_PER_TICK = 9  # the most a sensor draws at one tick (the pose sensor)
_UNIFORMS_PER_TICK = 2


class TickDraws:
    """One sensor's random numbers at one tick, served in order: the two np.random.Generator
    methods the sensors call (`standard_normal`, `random`).

    The numbers of (seed, sensor, tick) are a row of a block drawn by one generator for
    _BLOCK_TICKS ticks at once, `np.random.default_rng((seed, sensor, tick // _BLOCK_TICKS))`:
    a generator made per tick (its SeedSequence hashing, ~35 us) cost more than the sensors'
    mathematics. A sensor draws at most _NORMALS_PER_TICK normals and _UNIFORMS_PER_TICK
    uniforms a tick; one that asks for more is refused (ValueError), never given a reused number.
    """

    def __init__(self, normals: np.ndarray, uniforms: np.ndarray):
        self._normals, self._uniforms = normals, uniforms
        self._next_normal = self._next_uniform = 0

    def standard_normal(self, size: int) -> np.ndarray:
        """`size` standard normal numbers."""
        start, self._next_normal = self._next_normal, self._next_normal + size
        return self._take(self._normals, start, size)

    def random(self, size: int) -> np.ndarray:
        """`size` uniform numbers in [0, 1)."""
        start, self._next_uniform = self._next_uniform, self._next_uniform + size
        return self._take(self._uniforms, start, size)

    @staticmethod
    def _take(numbers: np.ndarray, start: int, size: int) -> np.ndarray:
        if start + size > len(numbers):
            raise ValueError(f"TickDraws: a sensor drew more than the {len(numbers)} per tick")
        return numbers[start : start + size].copy()


@dataclasses.dataclass(frozen=True)
class TruthSample:
    """What the sensors see of the truth at one event: the true sensed bundle and the chaser's
    orbit (its GNSS fix and its velocity change come from it)."""

    sensed: np.ndarray  # (33)
    chaser_state_I: np.ndarray  # (6) [p_IC_I, v_IC_I]


@dataclasses.dataclass(frozen=True)
class EstimateVersion:
    """The estimate after one fix, shown from the fix's arrival on.

    arrives_s: when the fix arrives (its time plus the latency).
    filter: the filter just after the fix, at the fix's time (its covariance the update's).
    estimate: its nominal carried to the navigation's last event (the thrust included).
    counts: (fixes used, rejected, filter restarts) with this fix.
    nis: the fix's normalised innovation squared.
    covariance: the filter's covariance carried to the estimate's time, when an event has
        carried it there (the prediction the next fix's update starts from); else None.
    """

    arrives_s: float
    filter: rn.FilterState
    estimate: rn.FilterState
    counts: tuple
    nis: float
    covariance: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class NavigationMemory:
    """Everything the navigation holds between events. Never changed in place: each event makes a
    new one, so Drake's clones of a context may share it."""

    tick: int = -1  # the tick of the last event (its time: start_s + tick * period)
    first_fix: rn.PoseMeasurement | None = None  # before the filter has started
    versions: tuple = ()  # EstimateVersion: the one shown at the last event, then those to come
    chaser_last: np.ndarray | None = None  # chaser_state_I at the last event (true)
    gravity_last: tuple | None = None  # the gravity at chaser_last (what its IMU removes)
    gyro_bias: np.ndarray | None = None
    q_IC: np.ndarray | None = None  # the chaser's attitude estimate at the last event
    w_IC_C: np.ndarray | None = None  # the gyro's mean rate over gyro_readings
    gyro_readings: tuple = ()  # (interval, mean rate) over the last gyro_window_s
    q_IC_true: np.ndarray | None = None  # the gyro's reference at the last event (its truth)
    target_I: np.ndarray | None = None  # the target's orbit estimate at the last event
    R_IL: np.ndarray | None = None  # its LVLH frame at the last event
    q_IL: np.ndarray | None = None
    w_IL_L: np.ndarray | None = None
    counts: tuple = (0, 0, 0, 0)  # fixes used, rejected, unseen; restarts (as taken, not shown)
    rejected_in_a_row: int = 0

    def __deepcopy__(self, memo):
        return self

    def shown(self, t: float) -> EstimateVersion | None:
        """The estimate shown at t (at or after the last event): that of the last fix arrived
        by t; None before the first."""
        index = _shown_index(self.versions, t)
        return self.versions[index] if index >= 0 else None


def _shown_index(versions, t: float) -> int:
    """The index of the version shown at t in `versions` (ordered by arrival); -1 if none."""
    index = -1
    for i, version in enumerate(versions):
        if version.arrives_s > t + _TIME_TOLERANCE_S:
            break
        index = i
    return index


class NavigationComputer:
    """The navigation's computation, event by event, on plain arrays: the system's updates and
    the lead-in call the same `tick`.

    Args:
        config: the scenario's Ekf block.
        seed: the scenario's seed.
        mean_motion_rad_s: the filter's CW mean motion (0 in free space).
        gravity: the truth's gravity model's name (the target orbit's propagation).
        boresight_C: the pose sensor's boresight, unit, in C.

    Time runs in ticks of `update_period_s` from the lead-in's start (tick 0, at `start_s`, a
    whole number of sensor cycles before t = 0, so that every schedule meets t = 0), but the
    navigation only works at its events: a sensor's sample (`is_event`). In between, nothing is
    due: the output carries the estimate to the instant it is read, and shows a fix's update
    from its arrival on (`NavigationMemory.shown`). Events, not a fixed clock, because every
    event ends an integrator step: at 10 Hz they made a run of paper 004's MPC take five times
    its steps; an event at each fix's arrival too made hold_point's navigation cost half as much
    again.
    """

    def __init__(
        self,
        config: Ekf,
        seed: int,
        mean_motion_rad_s: float,
        gravity: str,
        boresight_C,
    ):
        self.config = config
        self.seed = int(seed)
        self.n = float(mean_motion_rad_s)
        self.gravity = gravity
        self.boresight_C = np.asarray(boresight_C, dtype=float)
        self.period_s = config.update_period_s
        self.pose, self.star, self.gyro, self.gnss = scaled_sensors(config)
        self.settings = config.filter_settings()
        self.gate = rn.chi_square_quantile(self.settings.gate_probability, rn.MEASUREMENT_SIZE)
        self.every = {
            name: round(period / self.period_s) for name, period in config.sensor_periods().items()
        }
        self.latency_ticks = math.ceil(config.pose_sensor.latency_s / self.period_s - 1e-9)
        cycle = math.lcm(*self.every.values())
        lead_in_ticks = math.ceil(config.lead_in_s / self.period_s - 1e-9)
        self.start_s = -math.ceil(lead_in_ticks / cycle) * cycle * self.period_s
        self._orbit = (None, None)  # (the target orbit estimate, its TargetOrbit)
        self._blocks = {}  # (sensor, block) -> (normals, uniforms): TickDraws' blocks

    def time_of(self, tick: int) -> float:
        """The time of a tick [s]."""
        return self.start_s + tick * self.period_s

    def tick_at(self, t: float) -> int:
        """The tick at time t."""
        return round((t - self.start_s) / self.period_s)

    def is_event(self, tick: int) -> bool:
        """Whether the navigation works at this tick: a sensor samples."""
        return any(tick % every == 0 for every in self.every.values())

    def event_schedule(self) -> list[tuple[float, float]]:
        """The events as (period [s], offset from t = 0 [s]) pairs, each once."""
        return sorted((every * self.period_s, 0.0) for every in set(self.every.values()))

    def _rng(self, stream: int, tick: int) -> TickDraws:
        """The draws of one sensor (stream) at one tick (`TickDraws`)."""
        block, row = divmod(tick, _BLOCK_TICKS)
        key = (stream, block)
        numbers = self._blocks.get(key)
        if numbers is None:
            generator = np.random.default_rng((self.seed, stream, block))
            numbers = (
                generator.standard_normal((_BLOCK_TICKS, _NORMALS_PER_TICK)),
                generator.random((_BLOCK_TICKS, _UNIFORMS_PER_TICK)),
            )
            if len(self._blocks) >= 16:  # a run's ticks only go forward: keep the latest
                del self._blocks[next(iter(self._blocks))]
            self._blocks[key] = numbers
        return TickDraws(numbers[0][row], numbers[1][row])

    def _due(self, field: str, tick: int) -> bool:
        return tick % self.every[field] == 0

    # ------------------------------------------------------------------------------- filter

    def motion(self, target_I) -> float | TargetOrbit:
        """The filter's translation model (rpod.models.relative_navigation.predict): CW's mean
        motion, or with process_model 'exact' the relative motion about the target orbit
        estimate target_I (CW until there is one)."""
        if self.config.process_model == "cw" or target_I is None:
            return self.n
        key, orbit = self._orbit
        if key is not target_I:  # one TargetOrbit per estimate of the target's orbit
            orbit = TargetOrbit(target_I[:3], target_I[3:], self.gravity)
            self._orbit = (target_I, orbit)
        return orbit

    def _carry(
        self,
        state: rn.FilterState,
        t: float,
        increments,
        motion,
    ) -> rn.FilterState:
        """The nominal carried to t unforced, plus the thrust's increments over the interval
        (`_thrust_since`)."""
        out = rn.propagate_nominal(state, t, motion, _ZERO, self.settings.max_step_s)
        dp_L, dv_L = increments
        out.p_LC_L = out.p_LC_L + dp_L
        out.v_LC_L = out.v_LC_L + dv_L
        return out

    def _use(self, memory: dict, versions: list, fix: rn.PoseMeasurement, tick: int, motion):
        """One fix taken at this event: starts the filter, or updates it at the fix's time, and
        appends what it gives to `versions`, shown from the fix's arrival on."""
        used, rejected, unseen, restarts = memory["counts"]
        arrives_s = self.time_of(tick + self.latency_ticks)
        if not versions:
            if memory["first_fix"] is None:
                memory["first_fix"] = fix
            else:
                state = rn.initial_state(memory["first_fix"], fix, self.settings.prior)
                versions.append(
                    EstimateVersion(
                        arrives_s, state, state, (used + 1, rejected, restarts), math.nan
                    )
                )
            memory["counts"] = (used + 1, rejected, unseen, restarts)
            return
        # The filter carried to the fix: its nominal is the last version's estimate (carried
        # event by event through the thrust, a known input), its covariance predicted over
        # the interval (whose growth does not depend on the thrust).
        latest = versions[-1]
        s = self.settings
        covariance = rn.predict(
            latest.filter, fix.t, motion, s.noise, _ZERO, s.max_step_s, s.excitation_sigmas
        ).P
        versions[-1] = dataclasses.replace(latest, covariance=covariance)  # `covariance_at`
        state = dataclasses.replace(latest.estimate, P=covariance)
        result = rn.update(state, fix, self.gate, s.excitation_sigmas)
        in_a_row = 0 if result.accepted else memory["rejected_in_a_row"] + 1
        if in_a_row >= self.config.restart_after_rejections:
            # Not outliers: the filter has diverged (its model is wrong, or a manoeuvre it was
            # not told of). The part that diverged starts again from this fix, which it then
            # takes (rpod.models.relative_navigation.reset_diverged).
            period = 1.0 / self.pose.rate_hz
            reset, _ = rn.reset_diverged(state, fix, period, s.prior, s.gate_probability)
            result = rn.update(reset, fix, math.inf, s.excitation_sigmas)
            in_a_row = 0
            restarts += 1
        memory["rejected_in_a_row"] = in_a_row
        used, rejected = used + result.accepted, rejected + (not result.accepted)
        memory["counts"] = (used, rejected, unseen, restarts)
        versions.append(
            EstimateVersion(
                arrives_s, result.state, result.state, (used, rejected, restarts), result.nis
            )
        )

    # --------------------------------------------------------------------------------- tick

    def tick(self, previous: NavigationMemory, tick: int, truth: TruthSample) -> NavigationMemory:
        """The navigation after the event at tick `tick` (time `time_of(tick)`), from the one
        after the event before."""
        t = self.time_of(tick)
        t_last = self.time_of(previous.tick) if previous.tick >= 0 else t
        dt = t - t_last
        memory = {f.name: getattr(previous, f.name) for f in dataclasses.fields(previous)}
        sensed = Sensed.from_vector(truth.sensed)

        # The chaser's thrust since the last event, in L: its IMU's increments.
        increments = self._thrust_since(previous, truth.chaser_state_I, dt)
        memory["chaser_last"] = np.array(truth.chaser_state_I, dtype=float)
        memory["gravity_last"] = gravity_acceleration_xyz(
            *memory["chaser_last"][:3].tolist(), self.gravity
        )
        self._chaser_attitude(memory, previous, tick, sensed, dt)

        # Every estimate still shown or to come, carried to now through the thrust; those a
        # fix arrived since has replaced are dropped.
        motion = self.motion(previous.target_I)
        versions = list(previous.versions)
        shown = _shown_index(versions, t)
        versions = versions[max(shown, 0) :]
        if dt > 0.0:
            versions = [
                dataclasses.replace(
                    v, estimate=self._carry(v.estimate, t, increments, motion), covariance=None
                )
                for v in versions
            ]

        # A pose fix taken now: the filter updated at once, shown from its arrival.
        if self._due("pose_sensor.rate_hz", tick):
            R_IL, R_IC = rotations_from_wxyz(np.array([sensed.q_IL, sensed.q_IC]))
            R_LC = R_IL.T @ R_IC
            fix, _ = self.pose.measure(
                self._rng(_POSE, tick), t, sensed.p_LC_L, sensed.q_IT, R_LC, self.boresight_C
            )
            if fix is None:
                used, rejected, unseen, restarts = memory["counts"]
                memory["counts"] = (used, rejected, unseen + 1, restarts)
            else:
                fix = dataclasses.replace(
                    fix,
                    sigma_position_m=max(fix.sigma_position_m, _SIGMA_FLOOR_M),
                    sigma_attitude_rad=max(fix.sigma_attitude_rad, _SIGMA_FLOOR_RAD),
                )
                self._use(memory, versions, fix, tick, motion)
        memory["versions"] = tuple(versions)
        self._target_orbit(memory, previous, tick, truth, dt)
        memory["tick"] = tick
        return NavigationMemory(**memory)

    def _chaser_attitude(
        self, memory, previous: NavigationMemory, tick, sensed: Sensed, dt
    ) -> None:
        """The last star-tracker fix carried by the gyro (module docstring): the integrating
        gyro is read at every event, over the interval since the last (its mean rate is the
        truth's rotation over the interval, divided by it)."""
        bias = previous.gyro_bias
        if bias is None:
            bias = self.gyro.initial_bias(self._rng(_BIAS, 0))
        q = previous.q_IC
        if previous.q_IC_true is not None and dt > 0.0:
            true_mean = attitude_error(previous.q_IC_true, sensed.q_IC) / dt
            w, bias = self.gyro.measure(self._rng(_GYRO, tick), true_mean, bias, dt)
            if q is not None:
                q = quaternion_product(q, rotation_vector_quaternion(w * dt))
            readings = [*previous.gyro_readings, (dt, w)]
            while (
                len(readings) > 1 and sum(r[0] for r in readings[1:]) >= self.config.gyro_window_s
            ):
                readings.pop(0)  # the window: the last gyro_window_s of readings
            memory["gyro_readings"] = tuple(readings)
            memory["w_IC_C"] = sum(r[0] * r[1] for r in readings) / sum(r[0] for r in readings)
        memory["q_IC_true"] = np.array(sensed.q_IC)  # the gyro's own reference, not an estimate
        if self._due("star_tracker.rate_hz", tick) or q is None:
            q = self.star.measure(self._rng(_STAR, tick), sensed.q_IC)
        memory["gyro_bias"], memory["q_IC"] = bias, q
        if memory["w_IC_C"] is None:  # no reading yet: at rest, as far as it knows
            memory["w_IC_C"] = np.zeros(3)

    def _target_orbit(
        self, memory, previous: NavigationMemory, tick, truth: TruthSample, dt
    ) -> None:
        """The target's orbit: carried by gravity; at a GNSS fix, the fix less the relative
        estimate."""
        target = previous.target_I
        if target is not None:
            target = _gravity_step(target, dt, self.gravity)
        shown = _shown_index(memory["versions"], self.time_of(tick))
        estimate = memory["versions"][shown].estimate if shown >= 0 else None
        if estimate is not None and (self._due("gnss.rate_hz", tick) or target is None):
            p_IC, v_IC = self.gnss.measure(
                self._rng(_GNSS, tick), truth.chaser_state_I[:3], truth.chaser_state_I[3:]
            )
            # LVLH from the last orbit estimate (or the chaser's fix: tens of metres from the
            # target's at 7,000 km, a 1e-5 rad difference)
            reference = target if target is not None else np.concatenate([p_IC, v_IC])
            R_IL, w_IL_L = lvlh_of(reference[:3], reference[3:], self.gravity)
            p_TC_I = R_IL @ estimate.p_LC_L
            v_TC_I = R_IL @ (estimate.v_LC_L + cross(w_IL_L, estimate.p_LC_L))
            target = np.concatenate([p_IC - p_TC_I, v_IC - v_TC_I])
        memory["target_I"] = target
        if target is not None:
            memory["R_IL"], memory["w_IL_L"] = lvlh_of(target[:3], target[3:], self.gravity)
            memory["q_IL"] = quaternion_wxyz(memory["R_IL"])

    # ------------------------------------------------------------------------------- output

    def covariance_at(self, memory: NavigationMemory, t: float) -> np.ndarray:
        """The covariance (14, 14) of the estimate shown at t, carried to the last event
        (between fixes an event carries only the nominal; the covariance's growth does not
        depend on the thrust)."""
        shown = memory.shown(t)
        if shown is None:
            return np.full((rn.ERROR_SIZE, rn.ERROR_SIZE), np.nan)
        estimate, state = shown.estimate, shown.filter
        if estimate.t <= state.t + _TIME_TOLERANCE_S:
            return state.P
        if shown.covariance is not None:  # carried by this event's update already
            return shown.covariance
        s = self.settings
        return rn.predict(
            state,
            estimate.t,
            self.motion(memory.target_I),
            s.noise,
            _ZERO,
            s.max_step_s,
            s.excitation_sigmas,
        ).P

    def _thrust_since(self, memory: NavigationMemory, chaser_state_I, dt: float):
        """(dp_L, dv_L): what the chaser's thrust added to its relative position and velocity
        in L over the dt since memory's event. What an IMU's accelerometer gives the navigation
        computer integrated at its own rate (hundreds of Hz), emulated from the truth: the
        chaser's change beyond its start velocity and gravity in I, gravity taken linear in
        time over the interval (the trapezoid's error on its curvature along the orbit,
        dt^2 n^4 r / 12 ~ 2e-7 m/s^2 between events 0.5 s apart in low orbit, is far below
        the filter's acceleration noise; tests/systems/test_navigation_thrust.py):

            dv_I = int a ds,    dp_I = int (t1 - s) a ds,

        mapped into L to first order in the rotation w dt of L over the interval (w = w_IL_L;
        R = R_LI at the interval's start): the frame turning under the thrust (R_LI(s) =
        (I - [w x] (s - t0)) R) and the Coriolis coupling of the relative motion (Phi_vv(tau) =
        I - 2 [w x] tau, Phi_pv(tau) = I tau - [w x] tau^2) give

            dv_L = R dv_I - w x R (dt dv_I + dp_I),    dp_L = R dp_I - dt w x R dp_I.

        Left out, the velocity's n dt share of the thrust made a velocity error that grew with
        the interval: on hold_point's 1 m/s approach, 0.27 mm/s between 0.5 s events.
        Both increments, not a mean acceleration: a PWM fires early in its period, and a
        mean acceleration spread over the interval misplaces the position by a dt^2 / 8 each
        time, a bias the fixes then read as a velocity error (0.45 mm/s on hold_point).
        Zero before the first event."""
        if memory.chaser_last is None or memory.R_IL is None or not dt > 0.0:
            return _ZERO3, _ZERO3
        # On Python floats: this runs at every read of the estimate.
        x0, y0, z0, u0, v0, w0 = memory.chaser_last.tolist()
        x1, y1, z1, u1, v1, w1 = np.asarray(chaser_state_I, dtype=float).tolist()
        gx0, gy0, gz0 = memory.gravity_last
        gx1, gy1, gz1 = gravity_acceleration_xyz(x1, y1, z1, self.gravity)
        h, hh = 0.5 * dt, dt * dt
        dv_I = np.array(
            [u1 - u0 - h * (gx0 + gx1), v1 - v0 - h * (gy0 + gy1), w1 - w0 - h * (gz0 + gz1)]
        )
        dp_I = np.array(
            [
                x1 - x0 - u0 * dt - hh * (gx0 / 3.0 + gx1 / 6.0),
                y1 - y0 - v0 * dt - hh * (gy0 / 3.0 + gy1 / 6.0),
                z1 - z0 - w0 * dt - hh * (gz0 / 3.0 + gz1 / 6.0),
            ]
        )
        R_LI = memory.R_IL.T
        dp, dv = R_LI @ dp_I, R_LI @ dv_I
        w = memory.w_IL_L
        return dp - dt * cross(w, dp), dv - cross(w, dt * dv + dp)

    def sensed_at(
        self, memory: NavigationMemory, t: float, chaser_state_I, q_IC_true
    ) -> np.ndarray:
        """The `sensed` vector (33) the estimate gives at t (>= the last event's time), the
        chaser's thrust and rotation since that event included: its IMU is read at t (the
        accelerometer's increments, `_thrust_since`; the integrating gyro's angle since the
        event, the truth's rotation q_IC_true over it plus the bias, its white noise left out
        between events: at the default 0.15 deg/sqrt(h), 0.002 deg over 0.5 s, below the star
        tracker's 10 arcsec, 0.003 deg). Carried instead by the gyro's windowed mean rate, a slewing
        chaser's attitude was 0.4 deg off within the half second between events (paper 000's
        soft capture then spent 8 m/s more)."""
        shown = memory.shown(t)
        if shown is None or memory.target_I is None:
            return np.full(SENSED_SIZE, np.nan)
        state, target, q_IL, q_IC = shown.estimate, memory.target_I, memory.q_IL, memory.q_IC
        dt = t - state.t
        out = np.empty(SENSED_SIZE)  # rpod.systems.sensed's layout, filled in place
        if dt > 0.0:  # read between events: at most half a second on
            dp_L, dv_L = self._thrust_since(memory, np.asarray(chaser_state_I), dt)
            # One RK4 step: its error over 0.5 s at 10 deg/s of tumble is ~1e-6 rad. The
            # nominal alone, as `_carry` carries it (no state object: this runs at every read).
            x = rn.nominal_at(state, t, self.motion(memory.target_I), _ZERO, _OUTPUT_STEP_S)
            out[0:3], out[3:6], out[13:17], out[17:20] = (
                x[0:3] + dp_L,
                x[3:6] + dv_L,
                x[6:10],
                x[10:13],
            )
            target = _gravity_step(target, dt, self.gravity)
            q_IL = quaternion_product(q_IL, rotation_vector_quaternion(memory.w_IL_L * dt))
            turned_C = quaternion_product(quaternion_conjugate(memory.q_IC_true), q_IC_true)
            q_IC = quaternion_product(
                quaternion_product(q_IC, turned_C),
                rotation_vector_quaternion(memory.gyro_bias * dt),
            )
        else:
            out[0:3], out[3:6], out[13:17], out[17:20] = (
                state.p_LC_L,
                state.v_LC_L,
                state.q_IT,
                state.w_IT_T,
            )
        out[6:10], out[10:13] = q_IL, memory.w_IL_L
        out[20:24], out[24:27], out[27:33] = q_IC, memory.w_IC_C, target
        return out


def _gravity_step(state_I: np.ndarray, dt: float, gravity: str) -> np.ndarray:
    """A free orbit under the gravity model carried by dt (at most the half second between two
    events), to second order: p + v dt + g dt^2 / 2, v + g dt with g at the middle of the step
    (error ~5e-5 m and ~1e-7 m/s over 0.5 s in low orbit, far below a GNSS fix's)."""
    x, y, z, u, v, w = state_I.tolist()
    h = 0.5 * dt
    gx, gy, gz = gravity_acceleration_xyz(x + h * u, y + h * v, z + h * w, gravity)
    hh = h * dt
    return np.array(
        [
            x + dt * u + hh * gx,
            y + dt * v + hh * gy,
            z + dt * w + hh * gz,
            u + dt * gx,
            v + dt * gy,
            w + dt * gz,
        ]
    )


class RelativeNavigation(LeafSystem):
    """The sensors and the filter, ticking every `update_period_s` on the truth.

    Input ports:
        truth_sensed (33): the true bundle (rpod.systems.sensed's layout), what the sensors see.
        chaser_state_I (6): the chaser's true orbit (GNSS, and its velocity change).
    Output ports:
        sensed (33): the estimate, carried to the instant it is read (with the thrust and
            the rotation since the last event, from chaser_state_I and truth_sensed's q_IC:
            the only output that reads the inputs).
        estimate (15): [p_LC_L, v_LC_L, q_IT, w_IT_T, p_x, p_y] at the last event, of the
            last fix arrived.
        covariance (196): its error covariance (14 x 14, row by row) at the last event, in the
            error state [dp, dv, dtheta_T, dw_T, dk] of rpod.models.relative_navigation.
        navigation_status (5): STATUS_FIELDS (used, rejected and restarts as of the last fix
            arrived; unseen as of the last sample).

    Args:
        computer: the navigation's computation (its config, seed and models).
        start: the memory after the lead-in (its last tick ends at or before t = 0).
    """

    def __init__(self, computer: NavigationComputer, start: NavigationMemory):
        super().__init__()
        self._computer = computer
        self._truth_port = self.DeclareVectorInputPort("truth_sensed", SENSED_SIZE)
        self._chaser_port = self.DeclareVectorInputPort("chaser_state_I", 6)
        self._memory = self.DeclareAbstractState(Value[object](start))
        self.start_memory = start  # what the lead-in left: the estimate at t = 0
        # One event per schedule; where two meet, both calls compute the same memory (from the
        # same context), and the second takes the first's from `_done`.
        for period_s, offset_s in computer.event_schedule():
            self.DeclarePeriodicUnrestrictedUpdateEvent(period_s, offset_s, self._update)
        self._done = (None, None, None)  # (memory, tick, its successor)
        # Every output shows the fixes arrived by the instant it is read: state and time.
        state = {self.abstract_state_ticket(self._memory), self.time_ticket()}
        self.DeclareVectorOutputPort(
            "sensed",
            SENSED_SIZE,
            self._calc_sensed,
            state
            | {
                self.input_port_ticket(self._chaser_port.get_index()),
                self.input_port_ticket(self._truth_port.get_index()),
            },
        )
        self.DeclareVectorOutputPort("estimate", ESTIMATE_SIZE, self._calc_estimate, state)
        size = rn.ERROR_SIZE * rn.ERROR_SIZE
        self.DeclareVectorOutputPort("covariance", size, self._calc_covariance, state)
        self.DeclareVectorOutputPort(
            "navigation_status", len(STATUS_FIELDS), self._calc_status, state
        )

    @property
    def computer(self) -> NavigationComputer:
        """The computation it runs."""
        return self._computer

    def _memory_of(self, context) -> NavigationMemory:
        return context.get_abstract_state(self._memory).get_value()

    def _update(self, context, state) -> None:
        memory = self._memory_of(context)
        tick = self._computer.tick_at(context.get_time())
        done_memory, done_tick, after = self._done
        if done_memory is not memory or done_tick != tick:
            truth = TruthSample(
                np.array(self._truth_port.Eval(context)),
                np.array(self._chaser_port.Eval(context)),
            )
            after = self._computer.tick(memory, tick, truth)
            self._done = (memory, tick, after)
        state.get_mutable_abstract_state(self._memory).set_value(after)

    def _calc_sensed(self, context, output) -> None:
        truth = self._truth_port.Eval(context)
        output.SetFromVector(
            self._computer.sensed_at(
                self._memory_of(context),
                context.get_time(),
                self._chaser_port.Eval(context),
                truth[20:24],  # q_IC (rpod.systems.sensed's layout): what the gyro turns by
            )
        )

    def _calc_estimate(self, context, output) -> None:
        shown = self._memory_of(context).shown(context.get_time())
        if shown is None:
            output.SetFromVector(np.full(ESTIMATE_SIZE, np.nan))
            return
        output.SetFromVector(rn.nominal_vector(shown.estimate))

    def _calc_covariance(self, context, output) -> None:
        memory = self._memory_of(context)
        output.SetFromVector(self._computer.covariance_at(memory, context.get_time()).ravel())

    def _calc_status(self, context, output) -> None:
        memory = self._memory_of(context)
        shown = memory.shown(context.get_time())
        used, rejected, restarts = shown.counts if shown is not None else (0, 0, 0)
        nis = shown.nis if shown is not None else math.nan
        output.SetFromVector(np.array([used, rejected, memory.counts[2], restarts, nis]))
