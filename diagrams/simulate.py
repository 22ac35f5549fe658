"""Simulating a scenario: build its diagram, run it, collect the log, summarise the run.

Owns: `simulate` (a `SimulationResult` with logs, metrics and timings), where a run ends
(duration_s, or the controller's planned end with `stop.at_plan_end`), the final sample of the
log (the simulation's end, whatever the log period) and the collection of the loggers' samples
into the named arrays of log.npz.
Does not own: the wiring (builder.py), the run-level metrics (metrics.py), what a controller
adds (its plug-in's `results`), or files (rpod.scenarios.run).

A plug-in's `results` reads the log and never changes it: its `ControllerResults.log` entries
are added to the log (replacing a key of the same name, e.g. a logged (N, 1) code as int64),
and an entry whose value is None removes that key (a raw status vector the plug-in logged and
split into named arrays), so log.npz holds what the plug-in says it holds.
"""

import dataclasses
import time

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorStatus
from pydrake.systems.framework import EventStatus

from rpod.diagrams import controller_seam
from rpod.diagrams.builder import DiagramHandles, build_diagram
from rpod.diagrams.metrics import run_summary
from rpod.diagrams.mission import (
    Capture,
    CaptureWatch,
    capture_reach_m,
    capture_verdict,
    verdict_text,
)
from rpod.diagrams.navigation_results import navigation_log, navigation_summary
from rpod.diagrams.scenario import Scenario, scenario_warnings
from rpod.systems.lifetime import release_diagram
from rpod.systems.safety_monitor import ContactWatch
from rpod.systems.step_timer import compute_summary

PROGRESS_PERIOD_S = 0.5  # wall time between two progress calls


@dataclasses.dataclass
class SimulationResult:
    """What `simulate` returns.

    Attributes:
        log: time series keyed as in log.npz (time is the first axis of every array).
        summary: metrics, status and timings (the content of summary.json).
    """

    log: dict
    summary: dict


def _sample_final_state(context, handles: DiagramHandles) -> None:
    """Adds the state where the simulation stopped to every log, unless it is already there.

    The loggers sample every log_period_s; the run ends at duration_s (or where the integrator
    failed), which need not be a sample time. The final metrics (sim_time_s, the final state,
    delta-v) are read from the log's last row, so that row must be the simulation's end.
    """
    now = context.get_time()
    for logger in handles.loggers.values():
        times = logger.FindLog(context).sample_times()
        if len(times) == 0 or times[-1] < now:
            logger.ForcedPublish(logger.GetMyContextFromRoot(context))


def _collect_log(diagram, context, handles: DiagramHandles, scenario: Scenario) -> dict:
    """Turns the loggers' samples into the named arrays of log.npz."""
    raw = {}
    for key, logger in handles.loggers.items():
        samples = logger.FindLog(context)
        raw[key] = (samples.sample_times(), samples.data().T)
    t = raw["relative_state_L"][0]
    count = len(t)
    data = {key: value[1][:count] for key, value in raw.items()}
    log = {"t": t}
    log["p_LC_L"], log["v_LC_L"] = (
        data["relative_state_L"][:, 0:3],
        data["relative_state_L"][:, 3:6],
    )
    log["q_IT"], log["w_IT_T"] = data["target_attitude"][:, 0:4], data["target_attitude"][:, 4:7]
    log["q_IC"], log["w_IC_C"] = data["chaser_attitude"][:, 0:4], data["chaser_attitude"][:, 4:7]
    log["q_IL"], log["w_IL_L"] = data["q_IL"], data["w_IL_L"]
    log["p_IT_I"], log["v_IT_I"] = data["target_state_I"][:, 0:3], data["target_state_I"][:, 3:6]
    log["p_IC_I"], log["v_IC_I"] = data["chaser_state_I"][:, 0:3], data["chaser_state_I"][:, 3:6]
    log["chaser_mass_kg"] = data["chaser_mass"][:, 0]
    log["propellant_kg"] = scenario.chaser.mass_kg - log["chaser_mass_kg"]
    for key in (
        "separation_m",
        "penetration_m",
        "corridor_violation_rad",
        "capture_speed_m_s",
        "capture_distance_m",
        "port_distance_m",
    ):
        log[key] = data[key][:, 0]
    n = handles.layout.count if handles.layout is not None else 0
    zeros = np.zeros((count, n))
    if "thruster_force_C" in data:  # a gimbaled bank: the commanded force vectors (3 each)
        forces = data["thruster_force_C"]
        log["thruster_force_C"] = forces
        # Each thruster's throttle is its force's magnitude over its largest (no PWM).
        magnitude = np.linalg.norm(forces.reshape(count, n, 3), axis=2)
        log["thruster_duty"] = magnitude / handles.layout.max_thrusts_N
    for key in ("thruster_duty", "thruster_on", "thruster_delivered_duty"):
        if key in data:  # on-levels of fixed thrusters; delivered_duty only behind PWM
            log[key] = data[key]
    # No thrusters flying (an ideal actuator, or none): no duty logged, none drawn as zero.
    log["command_clipped"] = data.get("command_clipped", zeros)
    log["body_wrench"] = data.get("body_wrench", np.zeros((count, 6)))
    for key in handles.wiring.logged if handles.wiring is not None else ():
        log[key] = data[key]  # the controller's own signals, under the names it gave them
    if handles.navigation is not None:
        log.update(navigation_log(data, count))
    return log


def _end_time_s(scenario: Scenario, handles: DiagramHandles, context, warnings: list) -> float:
    """Where the run ends: duration_s, or the controller's planned end plus stop.hold_s when
    stop.at_plan_end asks and it is earlier. A plan that outlasts the run is a warning."""
    end_s = scenario.duration_s
    if handles.wiring is None:
        return end_s
    plugin = controller_seam.plugin_for(scenario.controller)
    planned = plugin.planned_end_s(handles.wiring, context)
    if planned is None:
        return end_s
    if planned > end_s:
        warnings.append(
            f"the controller's plan ends at {planned:.1f} s, after the run's end at "
            f"{end_s:.1f} s: raise duration_s (stop.at_plan_end then ends the run at the plan)"
        )
    if scenario.stop.at_plan_end:
        end_s = min(end_s, planned + scenario.stop.hold_s)
    return end_s


class _StepMonitor:
    """The Simulator's monitor: called after Initialize and after every integrator step.

    It adds no event, so nothing it does changes a step: it checks contact of the true shapes
    (ContactWatch), ends the run at its capture under `mission: !Capture` (CaptureWatch),
    publishes the scene (SceneDriver, when drawing) and reports progress.
    """

    def __init__(self, contact, scene_driver, progress, end_s: float, capture=None):
        self.contact = contact
        self._capture = capture
        self._scene = scene_driver
        self._progress = progress
        self.end_s = end_s
        self._next_progress_wall = time.perf_counter() + PROGRESS_PERIOD_S

    def __call__(self, root_context) -> EventStatus:
        self.contact.observe(root_context)
        if self._scene is not None:
            self._scene.observe(root_context)
        if self._progress is not None and time.perf_counter() >= self._next_progress_wall:
            self._progress(root_context.get_time(), self.end_s)
            self._next_progress_wall = time.perf_counter() + PROGRESS_PERIOD_S
        if self._capture is not None:
            return self._capture.observe(root_context)
        return EventStatus.Succeeded()


def contact_text(contact: dict) -> str:
    """The outcome line's words for a contact, e.g. 'CONTACT of the true shapes from
    86.52 to 87.10 s (1 interval, 221 mm deep)'."""
    first, last = contact["first_s"], contact["last_s"]
    when = f"at {first:.2f} s" if last - first < 5e-3 else f"from {first:.2f} to {last:.2f} s"
    count = contact["intervals"]
    return (
        f"CONTACT of the true shapes {when} ({count} interval{'s' if count != 1 else ''}, "
        f"{1000.0 * contact['max_depth_m']:.0f} mm deep)"
    )


def mission_verdict(outcome, contact: dict, has_controller: bool, capture=None) -> dict:
    """summary.json's `mission`: the verdict and the run's contact, joined.

    The verdict is the controller's own (`outcome`), or under `mission: !Capture` the capture
    criterion's (`capture`, rpod.diagrams.mission.capture_verdict, kept under `capture`).
    Contact of the true shapes anywhere in the run fails the mission whatever the criterion
    says (a safety event is never hidden by a success); the line then leads with it.
    `controller_success` keeps the plug-in's own verdict; `criterion` names the one judged.
    """
    controller_success = None if outcome is None else bool(outcome.success)
    if capture is not None:
        outcome = controller_seam.MissionOutcome(capture["success"], verdict_text(capture))
    if outcome is None:
        text = (
            "no mission criterion (the controller gives none)"
            if has_controller
            else "no controller: no mission to judge"
        )
        success = None
    else:
        text, success = outcome.text, bool(outcome.success)
    if contact["occurred"]:
        prefix = "NOT a success: " if success else ""
        text = f"{prefix}{contact_text(contact)}; {text}"
        success = False if success is not None else None
    verdict = {
        "success": success,
        "outcome": text,
        "criterion": "controller" if capture is None else "capture",
        "controller_success": controller_success,
        "contact": contact["occurred"],
    }
    if capture is not None:
        verdict["capture"] = capture
    return verdict


def simulate(scenario: Scenario, meshcat=None, progress=None) -> SimulationResult:
    """Builds and simulates a scenario; returns its logs and summary.

    Integrator failures do not raise: the run stops there, and `summary['status']` says why
    ('ok' or 'failed: ...'); the logs hold what was simulated.

    Args:
        scenario: a validated scenario.
        meshcat: draw and record the run there (None: no drawing). Drawing never changes the
            physics: the scene is published from the Simulator's monitor (SceneDriver).
        progress: called as progress(t_s, end_s) about every PROGRESS_PERIOD_S of wall time
            while the run goes on (None: silent).
    """
    start = time.perf_counter()
    diagram, handles = build_diagram(scenario, meshcat)
    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator, simulator)
    if meshcat is not None:
        from rpod.diagrams.recording import start_recording

        start_recording(meshcat, fps=max(1.0 / scenario.visualization.publish_period_s, 1.0))
    # Wall time from here: Initialize runs initialization events (a planning controller's
    # first plan), which belong to the simulation's cost, not the build's.
    built = time.perf_counter()
    status, warnings, stopped = "ok", scenario_warnings(scenario), None
    watch = ContactWatch(handles.monitor, handles.orbital)
    criterion = scenario.mission if isinstance(scenario.mission, Capture) else None
    capture_watch = None
    if criterion is not None and criterion.stop_at_capture:
        capture_watch = CaptureWatch(criterion, handles.monitor, watch, capture_reach_m(scenario))
    step_monitor = _StepMonitor(
        watch, handles.scene_driver, progress, scenario.duration_s, capture_watch
    )
    simulator.set_monitor(step_monitor)
    try:
        simulator.Initialize()
        end_s = _end_time_s(scenario, handles, simulator.get_context(), warnings)
        step_monitor.end_s = end_s  # known once Initialize has planned
        returned = simulator.AdvanceTo(end_s)
        if returned.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
            stopped = returned.message()  # a system ended the run on purpose: its words
    except RuntimeError as error:
        status = f"failed: {str(error).splitlines()[0]}"
    finished = time.perf_counter()
    context = simulator.get_context()
    _sample_final_state(context, handles)
    log = _collect_log(diagram, context, handles, scenario)
    if meshcat is not None:
        handles.scene_driver.finish(context)
        handles.scene.FrameCamera(log["p_LC_L"])
        meshcat.StopRecording()
        meshcat.PublishRecording()
    summary = {"status": status, **run_summary(log, scenario)}
    outcome = None
    if handles.wiring is not None:
        results = controller_seam.plugin_for(scenario.controller).results(
            scenario, handles.wiring, context, log
        )
        for key, value in results.log.items():  # None: a raw signal the plug-in has split
            if value is None:
                log.pop(key, None)
            else:
                log[key] = value
        summary.update(results.summary)
        if handles.wiring.step_timer is not None:
            summary.update(compute_summary(handles.wiring.step_timer))
        outcome = results.outcome
    if handles.navigation is not None:
        summary["navigation"] = navigation_summary(log, scenario.target.inertia_kg_m2)
    summary["warnings"] = warnings
    summary["stopped_early"] = stopped
    # "Did the simulation run" (status) apart from "did the mission succeed" (mission), and
    # contact of the true shapes, one event for every method, in both.
    summary["contact"] = watch.summary(log)
    capture = capture_verdict(log, criterion) if criterion is not None else None
    summary["mission"] = mission_verdict(
        outcome, summary["contact"], handles.wiring is not None, capture
    )
    integ = simulator.get_integrator()
    summary.update(
        wall_time_s=finished - built,
        build_time_s=built - start,
        real_time_factor=float(context.get_time() / max(finished - built, 1e-9)),
        integrator_steps=int(integ.get_num_steps_taken()),
        derivative_evaluations=int(integ.get_num_derivative_evaluations()),
    )
    # The run is over: let the diagram be freed with its last reference (pydrake keeps a
    # diagram with Python systems alive otherwise; rpod.systems.lifetime).
    simulator.clear_monitor()
    release_diagram(diagram, simulator, context)
    return SimulationResult(log=log, summary=summary)
