"""The wall-clock cost of a controller's control steps: what the shoot-out reports per method.

Owns: `StepTimer`, which wraps a controller's update callback and keeps the duration of every
call, and `compute_summary`, the summary entries every controller reports from it.
Does not own: what the steps compute (the controllers) or how a campaign pools the entries
(rpod.scenarios.comparison).

The durations are diagnostics, not state: they live on the timer, outside the Context, and a
run fills them once. `StepTimer.reset` empties them; simulate() builds a new diagram (and so new
timers) per run, so a run's figures are its own. A control step here is one call of the
controller's periodic (or initialisation) update: for a planner that replans inside some of its
steps, those steps carry the planning's cost, which is what a flight computer would have to
fit into the step.
"""

import array
import time

import numpy as np

from rpod.systems.lifetime import weak_method


class StepTimer:
    """Times each call of the callbacks it wraps (perf_counter, seconds)."""

    def __init__(self):
        self._durations = array.array("d")

    def timed(self, callback):
        """callback wrapped: each call's wall time is kept, its result returned unchanged.

        A bound method is held weakly (rpod.systems.lifetime.weak_method): the wrapper goes to
        C++ as an event handler and must not keep its system alive."""
        durations, clock, callback = self._durations, time.perf_counter, weak_method(callback)

        def wrapper(*args):
            start = clock()
            try:
                return callback(*args)
            finally:
                durations.append(clock() - start)

        return wrapper

    def reset(self) -> None:
        """Forget every duration kept so far."""
        del self._durations[:]

    @property
    def durations_s(self) -> np.ndarray:
        """The duration of every timed call so far, in call order [s]."""
        return np.frombuffer(self._durations, dtype=float).copy()


def compute_summary(timer: StepTimer) -> dict:
    """summary.json's entries of a controller's compute per control step: the count of steps
    and the median, 99th percentile and maximum of their wall time [ms]; the times are None
    when no step ran."""
    durations = timer.durations_s
    if durations.size == 0:
        return {
            "control_steps": 0,
            "control_step_ms_p50": None,
            "control_step_ms_p99": None,
            "control_step_ms_max": None,
        }
    p50, p99 = np.percentile(1e3 * durations, [50, 99])
    return {
        "control_steps": int(durations.size),
        "control_step_ms_p50": float(p50),
        "control_step_ms_p99": float(p99),
        "control_step_ms_max": float(1e3 * durations.max()),
    }
