"""Paper 003's approach planner, methods "ipopt" (the paper's solver) and "snopt": the joint NLP.

Owns: `solve_nlp`, one candidate duration solved as one NLP of the attitude and the translation
together (`_nlp_program`), started from `solve_scp`'s answer or the spiral guess and re-solved
once if the KOS labels changed. Does not own: the problem data it shares with the SCP
(`planar_approach_problem`), the SCP (`planar_approach_scp`), the config, the result and the
duration search (`planar_approach`), the checker (`planar_approach_check`).

Method: the joint NLP (attitude and translation together) through Drake, the KOS as smooth terms
(`keepout_smooth_terms`, at least 1e-3: ~0.2 mm), (8) as expressions of theta and F, re-solved
once if the labels changed. Started from the SCP answer (`nlp_warm_start="scp"`, default) they
confirm it; from the spiral guess ("guess") they are slow (Drake gives IPOPT no second
derivatives, limited-memory quasi-Newton, and SNOPT builds its own quasi-Newton Hessian) and
keep the guess's labels. Measured on 2 shared cores at the shortest Sec. V-A candidate
(N = 236): "scp" 0.4 s to J = 1.983; IPOPT and SNOPT from its answer 34 s and 4 s to J = 1.980 (the
SCP's polygons are up to 0.25 mm larger than the shapes); from the guess, 47 s and 42 s, both to
a worse local optimum, J = 2.873 (their State II labels, and so the heading bounds, are the
guess's) (benchmarks/results/planar_nlp.md; before (5') and the heading condition IPOPT took
315-330 s from the guess). At N = 864 and 1493 the polish alone takes 1-10 min. With (5')'s term
Drake's IPOPT stopped in "Error in step computation" from the SCP answer at N = 24
(w_terminal_velocity 100 and 1000; a SOLVER_FAILED status), where SNOPT confirms it; with
w_terminal_velocity = 0 IPOPT does.
"""

import numpy as np
from pydrake.solvers import (
    ExpressionConstraint,
    IpoptSolver,
    MathematicalProgram,
    SnoptSolver,
    SolutionResult,
    SolverOptions,
)

from rpod.models import planar_approach as pa
from rpod.planners import planar_approach_problem as problem
from rpod.planners.planar_approach_problem import PlanarPlanStatus
from rpod.planners.planar_approach_scp import solve_scp

_NLP_TERM_MARGIN = 1e-3
"""Lower bound of the NLP's keep-out terms (~0.2 mm on r_safe = 0.45 m): the answer sits on
the constraints at the samples, and the margin covers the chord between them."""


# ----------------------------------------------------------------------- NLP (IPOPT, SNOPT)


def solve_nlp(config, x0, duration_s, guess):
    """The joint NLP with IPOPT or SNOPT for one duration: (status, word, iterations, X, U)."""
    N, dt = problem.grid(config, duration_s)
    samples = problem.samples(config, N, dt)
    geometry = config.geometry
    solver = SnoptSolver() if config.solver == "snopt" else IpoptSolver()
    if not (solver.available() and solver.enabled()):
        return PlanarPlanStatus.SOLVER_UNAVAILABLE, f"{config.solver} unavailable", 0, None, None
    X_guess, U_guess = guess
    prefix = ""
    if config.nlp_warm_start == "scp":
        scp_status, _, _, X_scp, U_scp = solve_scp(config, x0, duration_s, guess)
        if scp_status == PlanarPlanStatus.SUCCESS:
            X_guess, U_guess = X_scp, U_scp
            prefix = "from the SCP answer: "
        else:
            prefix = f"from the guess (SCP: {scp_status.value}): "
    t = np.arange(N + 1) * dt

    def labels_of(X):
        wanted = problem.wanted(geometry, samples.to_target(samples.positions(X[:, :2])))
        return problem.labels(wanted, problem.aligned_samples(config, samples, X[:, 2], t))

    labels = labels_of(X_guess)
    options = SolverOptions()
    if config.solver == "snopt":
        options.SetOption(solver.id(), "Major iterations limit", int(config.nlp_max_iterations))
        options.SetOption(solver.id(), "Major optimality tolerance", config.nlp_tolerance)
        options.SetOption(solver.id(), "Major feasibility tolerance", config.nlp_tolerance)
        options.SetOption(solver.id(), "Iterations limit", 10**7)
        options.SetOption(solver.id(), "Superbasics limit", 10 * (N + 1) * 9)
    else:
        options.SetOption(solver.id(), "max_iter", int(config.nlp_max_iterations))
        options.SetOption(solver.id(), "tol", config.nlp_tolerance)
        options.SetOption(solver.id(), "constr_viol_tol", config.nlp_tolerance)
        options.SetOption(solver.id(), "print_level", 0)
    status, word, solves, X, U = PlanarPlanStatus.SOLVER_FAILED, "", 0, X_guess, U_guess
    for solves in (1, 2):  # one re-solve with the labels of the first answer
        prog, Xv, Uv = _nlp_program(config, x0, N, dt, samples, labels, X[:, 2])
        start = np.zeros(prog.num_vars())
        prog.SetDecisionVariableValueInVector(Xv, X, start)
        prog.SetDecisionVariableValueInVector(Uv, U, start)
        result = solver.Solve(prog, start, options)
        word = prefix + problem.solver_word(result)
        status = {
            SolutionResult.kSolutionFound: PlanarPlanStatus.SUCCESS,
            SolutionResult.kIterationLimit: PlanarPlanStatus.ITERATION_LIMIT,
            SolutionResult.kInfeasibleConstraints: PlanarPlanStatus.INFEASIBLE,
        }.get(result.get_solution_result(), PlanarPlanStatus.SOLVER_FAILED)
        if status != PlanarPlanStatus.SUCCESS:
            return status, word, solves, None, None
        X, U = result.GetSolution(Xv), result.GetSolution(Uv)
        new_labels = labels_of(X)
        if np.array_equal(new_labels, labels):
            break
        labels = new_labels
    return status, word, solves, X, U


def _nlp_program(config, x0, N, dt, samples, labels, theta_bar):
    """Eqs. 5-9 jointly, the keep-out as `keepout_smooth_terms` at the samples; the knots of
    State II samples facing the docking face (bounds on theta, on theta_bar's branch)."""
    prog = MathematicalProgram()
    X = prog.NewContinuousVariables(N + 1, 6, "x")
    U = prog.NewContinuousVariables(N, 3, "F")
    m, inertia = config.chaser_mass_kg, config.chaser_inertia_kg_m2
    prog.AddBoundingBoxConstraint(x0, x0, X[0])  # (6)
    theta_f = pa.chaser_final_attitude(config.theta_approach_rad, x0[2])
    prog.AddBoundingBoxConstraint(theta_f, theta_f, X[N, 2])  # (6)
    # (7): x_k+1 - x_k - dt f(x_k, F_k) = 0, one small binding per step.
    A = np.hstack([-np.eye(6), np.eye(6), np.zeros((6, 3))])
    A[[0, 1, 2], [3, 4, 5]] = -dt
    A[[3, 4, 5], [12, 13, 14]] = -dt / np.array([m, m, inertia])
    for k in range(N):
        prog.AddLinearEqualityConstraint(A, np.zeros(6), np.concatenate([X[k], X[k + 1], U[k]]))
    Q = dt * np.diag([m, m, inertia, 2.0 * config.w_u, 2.0 * config.w_u, 2.0 * config.w_u])
    for k in range(N):  # (5)
        prog.AddQuadraticCost(Q, np.zeros(6), np.concatenate([X[k, 3:], U[k]]), is_convex=True)
    prog.AddQuadraticErrorCost(config.w_goal * np.eye(2), config.goal_position, X[N, :2])
    if config.w_terminal_velocity > 0.0:  # (5')
        M = problem.relative_velocity_map(config.omega_target_rad_s)
        Q_v = 2.0 * config.w_terminal_velocity * M.T @ M
        prog.AddQuadraticCost(Q_v, np.zeros(4), X[N, [0, 1, 3, 4]], is_convex=True)
    if config.goal_constraint:  # hard here: the NLP starts from the SCP's answer
        A_goal, b_goal = problem.goal_rows(config)
        prog.AddLinearEqualityConstraint(A_goal, b_goal, X[N, [0, 1, 3, 4]])
    # State II only facing the docking face (`planar_approach_problem`).
    wanted = labels == pa.STATE_II
    if np.any(wanted) and config.state_ii_heading:
        face = problem.face_heading(config, np.arange(N + 1) * dt, theta_f)
        knots, face = problem.alignment_targets(samples, wanted, theta_bar, face, N)
        bound = config.geometry.alignment_tolerance_rad * (1.0 - 10.0 * problem.REGION_SHRINK)
        for k in np.flatnonzero(knots):
            prog.AddBoundingBoxConstraint(face[k] - bound, face[k] + bound, X[k, 2])
    # (8) in the body frame.
    fmax, tmax = config.max_force_N, config.max_torque_Nm
    prog.AddBoundingBoxConstraint(-tmax, tmax, U[:, 2])
    kappa = 2.0 * fmax / tmax
    for k in range(N):
        fx, fy, tau = pa.body_wrench(X[k, 2], U[k])
        rows, bound = [fx, fy], [fmax, fmax]
        if config.wrench_limit == "planar_8":
            rows += [fx + fy + kappa * tau, fx + fy - kappa * tau]
            rows += [fx - fy + kappa * tau, fx - fy - kappa * tau]
            bound += [2.0 * fmax] * 4
        bound = np.array(bound)
        constraint = ExpressionConstraint(np.array(rows), -bound, bound)
        prog.AddConstraint(constraint, constraint.vars())
    # (9) at the samples, in each sample's labelled state.
    P = X[:, :2]
    for j in range(samples.size):
        k, s = int(samples.k[j]), float(samples.s[j])
        if s == 0.0 or s == 1.0:
            p = P[k + int(s)]
        else:  # Expressions built one by one (a numpy ufunc on them reports stale FP flags)
            p = [(1.0 - s) * P[k, i] + s * P[k + 1, i] for i in range(2)]
        terms = pa.keepout_smooth_terms(
            p, samples.theta_t[j], config.geometry, labels[j], config.smooth_max_sharpness
        )
        terms = np.array(terms)
        lower = np.full(len(terms), _NLP_TERM_MARGIN)
        constraint = ExpressionConstraint(terms, lower, np.full(len(terms), np.inf))
        prog.AddConstraint(constraint, constraint.vars())
    return prog, X, U
