"""Paper 000's algorithm at one horizon N: Problem 2, then the sequential convex Problem 3.

Owns: the iteration of Fig. 4 for a fixed N -- solve Problem 2; evaluate the collision metric
alpha at every knot of the iterate (chaser hull at the pointing-law pose, target hull at the
predicted pose); stop when alpha_k > 1 at every knot and every step keeps the field of view
(the hard test, below; alpha_min is only the margin the linearised rows ask for, with
penalised slack); otherwise linearise alpha about the
iterate (25) and solve Problem 3; at most i_max Problem 3 solves. Does not own: the programs
(``soft_capture_socp``), the horizon search, the config and the result type
(``soft_capture``).

Linearisation (25): ``J_k = d alpha / d p_a + (d alpha / d theta_a) d theta_k / d r_k``, with
the metric's gradient (``rpod.models.collision``, chaser = body a) and the pointing law's
rotation Jacobian (``rpod.planners.pointing``), earlier attitudes held fixed as in the paper.
No trust region (the paper omits it: corrections are small in this uncrowded space).

The hard test also asks the true field-of-view angle (12) of every step to be at most
omega_max dt (to 1e-6 rad, the solver's feasibility tolerance on metre-scale chords): Problem 2
enforces (12) only through the lifted relaxation, which can be loose; a Problem 2 solution that
fails it goes on to Problem 3, whose (FOV-i) cones enforce (12) (``soft_capture_socp``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from rpod.models.collision import ScalingMetricProgram
from rpod.planners.pointing import pointing_attitudes, pointing_rotation_jacobian
from rpod.planners.soft_capture_socp import SocpData, SocpSolution, SoftCaptureSocp

# Drake SolutionResult names that mean "the convex problem has no solution" (as opposed to a
# numerical failure of the solver): they map to the *_infeasible statuses.
_INFEASIBLE_RESULTS = ("kInfeasibleConstraints", "kInfeasibleOrUnbounded", "kDualInfeasible")
# Slack on the true line-of-sight step in the hard test: Clarabel's feasibility tolerance
# (1e-8 relative) on chords of metres is ~1e-9 rad; 1e-6 rad is far below any physical effect.
_LOS_TOLERANCE_RAD = 1e-6


@dataclass
class HorizonOutcome:
    """The algorithm's outcome at one horizon N.

    Attributes:
        N: Number of knots.
        status: ``"success"``; ``"initial_state_in_collision"`` (alpha_0 <= 1, no plan can
            pass); ``"problem2_infeasible"`` / ``"problem2_solver_failure"``;
            ``"problem3_infeasible"`` / ``"problem3_solver_failure"``;
            ``"collision_metric_failed"``; ``"scp_max_iterations"``.
        reason: One line with the solver's own word (Clarabel status, Drake SolutionResult).
        solve_time_s: Wall time of every SOCP solve at this N, Problem 2 first [s].
        step_time_s: Wall time of every step at this N [s]: step 0 is Problem 2 (data, solve)
            and its alpha check; step i >= 1 is SCP iteration i (pointing Jacobian,
            linearisation, Problem 3 solve) and the alpha check of its iterate. The sum of the
            first i + 1 is the cumulative time after i SCP iterations, as Sec. VI-B reports it.
            The alpha LPs' gradients, needed only to linearise, are timed in the step before.
        scp_iterations: Problem 3 solves performed.
        x: Last iterate's states (N, 6), or None if Problem 2 failed.
        u: Last iterate's forces (N-1, 3) [N], or None.
        rho: Last iterate's range lift (N,), or None.
        slack: Last iterate's collision slacks (N,), or None.
        R_LC: Pointing-law attitudes (N, 3, 3) of the last iterate, or None.
        alpha: Collision metric of the last iterate (N,), or None.
        cost: Objective value of the last solve (NaN if none succeeded).
    """

    N: int
    status: str
    reason: str
    solve_time_s: list[float] = field(default_factory=list)
    step_time_s: list[float] = field(default_factory=list)
    scp_iterations: int = 0
    x: np.ndarray | None = None
    u: np.ndarray | None = None
    rho: np.ndarray | None = None
    slack: np.ndarray | None = None
    R_LC: np.ndarray | None = None
    alpha: np.ndarray | None = None
    cost: float = float("nan")


def line_of_sight_angles(p_LC_L: np.ndarray) -> np.ndarray:
    """True angles (N-1,) between successive positions (12), by atan2 (exact at small angles)."""
    a, b = p_LC_L[:-1], p_LC_L[1:]
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))


def _failure_status(problem: str, solution: SocpSolution) -> tuple[str, str]:
    kind = "infeasible" if solution.solution_result in _INFEASIBLE_RESULTS else "solver_failure"
    reason = f"{problem}: {solution.solver} {solution.solver_status} ({solution.solution_result})"
    return f"{problem.lower().replace(' ', '')}_{kind}", reason


def evaluate_alpha(
    metric: ScalingMetricProgram,
    p_LC_L: np.ndarray,
    R_LC: np.ndarray,
    R_LT: np.ndarray,
    with_gradient: bool,
):
    """alpha at every knot (chaser = body a at (R_LC, p_LC_L); target = body b at (R_LT, 0)).

    Returns:
        ``(alpha (N,), grad_p (N, 3), grad_theta (N, 3), statuses)``; the gradients are None
        unless ``with_gradient``.
    """
    N = len(p_LC_L)
    origin = np.zeros((N, 3))
    metrics = metric.evaluate_many(R_LC, p_LC_L, R_LT, origin)  # the N LPs in one solve
    alpha = np.array([result.alpha for result in metrics])
    statuses = [result.status for result in metrics]
    grad_p = grad_theta = None
    if with_gradient:
        grad_p = np.array([result.d_alpha_d_p_a for result in metrics])
        grad_theta = np.array([result.d_alpha_d_theta_a for result in metrics])
    return alpha, grad_p, grad_theta, statuses


def solve_horizon(
    config,
    problem2: SoftCaptureSocp,
    problem3: SoftCaptureSocp,
    data: SocpData,
    R_LT: np.ndarray,
    metric: ScalingMetricProgram,
    R_LC0: np.ndarray | None = None,
) -> HorizonOutcome:
    """Problem 2, then up to ``config.max_scp_iterations`` Problem 3 solves, at one N.

    Args:
        config: A validated ``SoftCaptureConfig``.
        problem2: The Problem 2 program for this N.
        problem3: The Problem 3 program for this N.
        data: Initial state and terminal / docking data for this N.
        R_LT: Predicted target attitudes (N, 3, 3) at the knots.
        metric: The scaling-metric LP for (chaser hull, target hull).
        R_LC0: Chaser attitude before knot 0 for the pointing law (None: identity).

    Returns:
        The outcome; never raises on infeasibility or solver failure.
    """
    N = problem2.N
    phi = config.max_los_rate_rad_s * config.dt_s
    capture_axis_C = np.asarray(config.p_CDc_C, dtype=float)
    outcome = HorizonOutcome(N=N, status="", reason="")
    clock = time.perf_counter()

    problem2.set_data(data)
    solution = problem2.solve()
    outcome.solve_time_s.append(solution.solve_time_s)
    if not solution.success:
        outcome.status, outcome.reason = _failure_status("Problem 2", solution)
        return outcome
    problem3.set_data(data)

    iteration = 0
    while True:
        x = solution.x
        R_LC = pointing_attitudes(x[:, :3], capture_axis_C, R_LC0)
        need_gradient = iteration < config.max_scp_iterations
        alpha, grad_p, grad_theta, statuses = evaluate_alpha(
            metric, x[:, :3], R_LC, R_LT, need_gradient
        )
        now = time.perf_counter()
        outcome.step_time_s.append(now - clock)
        clock = now
        outcome.x, outcome.u, outcome.rho, outcome.slack = (
            x,
            solution.u,
            solution.rho,
            solution.slack,
        )
        outcome.R_LC, outcome.alpha, outcome.cost = R_LC, alpha, solution.cost
        outcome.scp_iterations = iteration
        bad = [s for s in statuses if s != "ok"]
        if bad:
            outcome.status = "collision_metric_failed"
            outcome.reason = f"scaling-metric LP: {bad[0]} at {len(bad)} knot(s)"
            return outcome
        if alpha[0] <= 1.0:
            outcome.status = "initial_state_in_collision"
            outcome.reason = f"alpha at the initial state is {alpha[0]:.4f} <= 1"
            return outcome
        los_excess = float(np.max(line_of_sight_angles(x[:, :3]))) - phi
        if np.all(alpha > 1.0) and los_excess <= _LOS_TOLERANCE_RAD:  # hard test, Sec. V-C
            outcome.status = "success"
            which = "Problem 2" if iteration == 0 else f"Problem 3 iteration {iteration}"
            outcome.reason = (
                f"alpha > 1 at every knot (min {alpha.min():.4f}) and every line-of-sight step "
                f"<= omega_max dt after {which}"
            )
            return outcome
        if not need_gradient:
            outcome.status = "scp_max_iterations"
            outcome.reason = (
                f"after {iteration} Problem 3 iterations (i_max = {config.max_scp_iterations}): "
                f"min alpha {alpha.min():.4f}, line-of-sight step excess {los_excess:.2e} rad"
            )
            return outcome
        # Linearisation (25) about the current iterate.
        dtheta_dr = pointing_rotation_jacobian(x[:, :3], capture_axis_C, R_LC0)
        J = grad_p + np.einsum("ki,kij->kj", grad_theta, dtheta_dr)
        J[0] = 0.0  # knot 0 is fixed (and its increment may be antiparallel: NaN)
        problem3.set_linearisation(alpha, J, x[:, :3])
        solution = problem3.solve()
        outcome.solve_time_s.append(solution.solve_time_s)
        iteration += 1
        if not solution.success:
            outcome.scp_iterations = iteration
            outcome.status, outcome.reason = _failure_status("Problem 3", solution)
            return outcome
