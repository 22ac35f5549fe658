"""Puts the scenario's navigation in the diagram: the truth's bundle, or sensors and a filter.

Owns: `add_navigation` (what the controllers' `sensed` port is) and the lead-in, the truth
before t = 0 on which the sensors and the filter run until the scenario starts.
Does not own: the navigation itself (rpod.systems.navigation), the truth (rpod.systems.truth).

The lead-in integrates the scenario's own truth (the same `Truth` system, coasting) backwards
from its start with scipy's DOP853 at rtol 1e-11: the orbits and the torque-free tumble are
time-reversible, so the samples are the states the run came from, not a second model's guess.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rpod.models import relative_navigation as rn
from rpod.models.config import ConfigError
from rpod.models.gravity import MU_EARTH_M3_S2, R_EARTH_M
from rpod.systems.navigation import (
    NavigationComputer,
    NavigationMemory,
    RelativeNavigation,
    TruthSample,
)
from rpod.systems.navigation_config import Ekf
from rpod.systems.sensed import SENSED_FIELDS

LEAD_IN_RTOL = 1e-11


def filter_mean_motion(scenario) -> float:
    """The CW mean motion of the filter's process model: the target's circular orbit's (0 in
    free space)."""
    if scenario.orbit.gravity == "free_space":
        return 0.0
    return math.sqrt(MU_EARTH_M3_S2 / (R_EARTH_M + scenario.orbit.altitude_m) ** 3)


def boresight_of(config: Ekf, scenario) -> np.ndarray:
    """The pose sensor's unit boresight in C: the config's, or the capture axis."""
    axis = np.asarray(config.boresight_C or scenario.chaser.capture_point_C, dtype=float)
    norm = float(np.linalg.norm(axis))
    if not norm > 1e-9:
        raise ConfigError(
            "navigation.boresight_C",
            "not given, and chaser.capture_point_C is at the centre of mass: name the sensor's "
            "boresight",
        )
    return axis / norm


def lead_in_states(truth, times_s) -> np.ndarray:
    """The coasting truth's continuous state (len(times_s), 27) at each of times_s (<= 0),
    integrated backwards from its default context (t = 0)."""
    from scipy.integrate import solve_ivp  # at use (rpod's imports stay light)

    context = truth.CreateDefaultContext()
    derivatives = truth.AllocateTimeDerivatives()
    x0 = context.get_continuous_state_vector().CopyToVector()

    def rates(t, x):
        context.SetTime(t)
        context.SetContinuousState(x)
        truth.CalcTimeDerivatives(context, derivatives)
        return derivatives.CopyToVector()

    times = np.asarray(times_s, dtype=float)
    if not times.size or times.min() >= 0.0:
        return np.tile(x0, (times.size, 1))
    solution = solve_ivp(
        rates,
        (0.0, float(times.min())),
        x0,
        method="DOP853",
        rtol=LEAD_IN_RTOL,
        atol=1e-9,
        dense_output=True,
    )
    if not solution.success:
        raise RuntimeError(
            f"navigation lead-in: the backward integration failed: {solution.message}"
        )
    return np.array([x0 if t == 0.0 else solution.sol(t) for t in times])


def lead_in_samples(truth, times_s) -> list[TruthSample]:
    """What the sensors see of the coasting truth at each of times_s (<= 0)."""
    context = truth.CreateDefaultContext()
    samples = []
    for t, x in zip(times_s, lead_in_states(truth, times_s)):
        context.SetTime(float(t))
        context.SetContinuousState(x)
        sensed = np.concatenate(
            [truth.GetOutputPort(name).Eval(context) for name, _ in SENSED_FIELDS]
        )
        chaser = np.array(truth.GetOutputPort("chaser_state_I").Eval(context))
        samples.append(TruthSample(sensed, chaser))
    return samples


def navigation_computer(config: Ekf, scenario) -> NavigationComputer:
    """The navigation's computation for the scenario (its lead-in starts about `lead_in_s`
    before 0: a whole number of sensor cycles)."""
    return NavigationComputer(
        config,
        scenario.seed,
        filter_mean_motion(scenario),
        scenario.orbit.gravity,
        boresight_of(config, scenario),
    )


def run_lead_in(computer: NavigationComputer, coasting_truth) -> NavigationMemory:
    """The navigation after every tick before t = 0; ConfigError when its filter has not
    started by then (the pose sensor saw the target fewer than twice)."""
    events = [k for k in range(computer.tick_at(0.0)) if computer.is_event(k)]
    samples = lead_in_samples(coasting_truth, [computer.time_of(k) for k in events])
    memory = NavigationMemory()
    for k, sample in zip(events, samples):
        memory = computer.tick(memory, k, sample)
    if memory.shown(0.0) is None:
        used, _, unseen, _ = memory.counts
        raise ConfigError(
            "navigation.lead_in_s",
            f"the filter has not started by t = 0: the pose sensor gave {used} fix(es) in the "
            f"{-computer.start_s:g} s lead-in ({unseen} without the target in its field of view "
            "or range window); it needs two, and the latency: lengthen the lead-in, or widen "
            "pose_sensor.half_fov_deg or its range window",
        )
    return memory


def add_navigation(builder, scenario, coasting_truth) -> RelativeNavigation:
    """Adds the scenario's Ekf navigation, started by its lead-in on `coasting_truth` (a
    `Truth` of the scenario with no thrust input); its input ports are left for the caller."""
    config = scenario.navigation
    computer = navigation_computer(config, scenario)
    start = run_lead_in(computer, coasting_truth)
    return builder.AddNamedSystem("navigation", RelativeNavigation(computer, start))


def with_estimated_inertia(scenario, navigation: RelativeNavigation):
    """The scenario as the controller is built from it on an estimate: the target's inertia is
    the one the navigation estimated by t = 0, its principal axes T's, its ratios the filter's,
    its magnitude the truth's trace (stated, not estimated: the torque-free tumble a planner
    predicts depends on the ratios only, and no pose sensor sees the mass). The truth and the
    verdict keep the scenario's own."""
    estimate = navigation.start_memory.shown(0.0).estimate
    ratios = rn.ratios_from_parameters(estimate.inertia_parameters)
    trace = float(np.trace(np.asarray(scenario.target.inertia_kg_m2, dtype=float)))
    diagonal = trace / (1.0 + ratios[0] + ratios[1]) * np.array([1.0, ratios[0], ratios[1]])
    target = dataclasses.replace(scenario.target, inertia_kg_m2=np.diag(diagonal).tolist())
    return dataclasses.replace(scenario, target=target)
