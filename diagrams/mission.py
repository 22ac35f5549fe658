"""A run's mission: each controller's own criterion, or one capture criterion for every method.

Owns: the scenario's `mission:` block, chosen by YAML tag like `controller:` and `navigation:`:
`!ControllerCriterion {}` (the default: each plug-in judges its own mission, e.g. the hold point
held) or `!Capture {...}` (paper 000's capture criterion, judged the same way whatever flies:
what lets methods be compared on one task); `capture_verdict` (that criterion on a run's log)
and `CaptureWatch` (which ends a run at its capture).
Does not own: the capture points' distance and relative speed (rpod.systems.safety_monitor
gives them for every run), contact (rpod.systems.safety_monitor.ContactWatch), or joining the
verdict with contact (rpod.diagrams.simulate.mission_verdict).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from pydrake.systems.framework import EventStatus

from rpod.models.config import positive


@dataclasses.dataclass
class ControllerCriterion:
    """Each controller judges its own mission (its plug-in's `results`): the default."""


@dataclasses.dataclass
class Capture:
    """Success is capture, judged alike for every controller (paper 000 eqs. 13-14, Table I): the
    capture points -- the chaser's E (chaser.capture_point_C) and the target's docking port D
    (target.docking_port_T) -- within position_tol_m of each other, their inertial relative
    speed within speed_tol_m_s, the true shapes not having touched before, within the run.

    position_tol_m, speed_tol_m_s: eps_p and eps_v (Table I: 0.35 m, 0.03 m/s).
    stop_at_capture: end the run at the first integrator step where the criterion holds (a
        capture mechanism latches there; what a method would do after it is not compared);
        otherwise the criterion is read at the log samples, and a contact after the capture
        still fails the mission (rpod.diagrams.simulate.mission_verdict).
    """

    position_tol_m: float = positive(0.35, high=100.0)
    speed_tol_m_s: float = positive(0.03, high=10.0)
    stop_at_capture: bool = True


def capture_verdict(log: dict, criterion: Capture) -> dict:
    """The capture criterion on a run's log (the safety monitor's capture_distance_m,
    capture_speed_m_s and separation_m at every sample; the last sample is where the run
    ended, so a run stopped at its capture is judged there): `judge_capture` on them."""
    return judge_capture(
        log["t"],
        log["capture_distance_m"],
        log["capture_speed_m_s"],
        log["separation_m"],
        criterion.position_tol_m,
        criterion.speed_tol_m_s,
    )


def judge_capture(t, distance, speed, separation, eps_p: float, eps_v: float) -> dict:
    """Capture on sampled signals: the first sample with the capture points' distance within
    eps_p and their relative speed within eps_v, no sample with the shapes touching
    (separation <= 0) before it.

    Returns:
        {success, reason, time_s, position_error_m, speed_error_m_s, first_contact_s}: at the
        capture sample, or when it failed at the first contact or at the sample closest to
        meeting both tolerances (least max(distance / eps_p, speed / eps_v)), the reason
        naming which tolerance was missed and by how much; first_contact_s is NaN without
        contact.
    """
    distance, speed = np.asarray(distance, float), np.asarray(speed, float)
    met = np.flatnonzero((distance <= eps_p) & (speed <= eps_v))
    contact = np.flatnonzero(~(np.asarray(separation, float) > 0.0))
    first_contact = int(contact[0]) if len(contact) else None
    # A Python bool (summary.json's): `first_contact > met[0]` alone is numpy's.
    success = bool(len(met)) and bool(first_contact is None or first_contact > met[0])
    if success:
        i = int(met[0])
        reason = f"capture points within {eps_p} m and {eps_v} m/s, no contact before"
    elif first_contact is not None:
        i = first_contact
        reason = f"contact: the true shapes touched at t = {t[i]:.2f} s"
    else:
        i = int(np.argmin(np.maximum(distance / eps_p, speed / eps_v)))
        if not np.any(distance <= eps_p):
            reason = (
                f"position: the capture points never came within {eps_p} m "
                f"(closest {distance.min():.3f} m)"
            )
        else:
            reason = (
                f"speed: within {eps_p} m their relative speed never fell to {eps_v} m/s "
                f"(least {speed[distance <= eps_p].min():.4f} m/s)"
            )
    return {
        "success": success,
        "reason": reason,
        "time_s": float(t[i]),
        "position_error_m": float(distance[i]),
        "speed_error_m_s": float(speed[i]),
        "first_contact_s": float(t[first_contact]) if first_contact is not None else math.nan,
    }


def verdict_text(verdict: dict) -> str:
    """The outcome line of a capture verdict."""
    if verdict["success"]:
        return (
            f"captured at {verdict['time_s']:.1f} s to {verdict['position_error_m']:.3f} m and "
            f"{verdict['speed_error_m_s']:.3f} m/s"
        )
    return f"NOT captured: {verdict['reason']}"


class CaptureWatch:
    """Ends a run at its capture (`Capture.stop_at_capture`): called by simulate's Simulator
    monitor after every integrator step, after the contact watch, it reads the safety
    monitor's capture outputs, so it adds no event and changes no step. While the chaser's
    centre is farther from the target's than |r_CE| + |r_TD| + eps_p (the contact watch has
    just measured it), the capture points cannot be within eps_p (the triangle inequality) and
    nothing is evaluated.
    """

    def __init__(self, criterion: Capture, monitor, contact, reach_m: float):
        """Args:
        criterion: the scenario's Capture block.
        monitor: the diagram's SafetyMonitor (its capture outputs are read).
        contact: the run's ContactWatch, observed at the same step just before (its
            `origin_distance_m` is the gate; a capture after a contact is no capture).
        reach_m: |r_CE| + |r_TD|, the capture points' distances from their bodies' centres.
        """
        self._criterion = criterion
        self._monitor = monitor
        self._contact = contact
        self._gate_m = reach_m + criterion.position_tol_m
        self._distance = monitor.GetOutputPort("capture_distance_m")
        self._speed = monitor.GetOutputPort("capture_speed_m_s")

    def observe(self, root_context) -> EventStatus:
        """Succeeded, or ReachedTermination once the capture points meet the criterion."""
        if self._contact.origin_distance_m > self._gate_m or self._contact.interval_count > 0:
            return EventStatus.Succeeded()
        context = self._monitor.GetMyContextFromRoot(root_context)
        distance = self._distance.Eval(context)[0]
        if distance > self._criterion.position_tol_m:
            return EventStatus.Succeeded()
        speed = self._speed.Eval(context)[0]
        if speed > self._criterion.speed_tol_m_s:
            return EventStatus.Succeeded()
        return EventStatus.ReachedTermination(
            self._monitor,
            f"captured at {root_context.get_time():.2f} s (mission: !Capture): "
            f"{distance:.3f} m, {speed:.4f} m/s",
        )


def capture_reach_m(scenario) -> float:
    """|r_CE| + |r_TD|: how far the capture points sit from their bodies' centres."""
    return math.hypot(*scenario.chaser.capture_point_C) + math.hypot(
        *scenario.target.docking_port_T
    )
