"""Paper 003's approach planner, method "scp" (the default): sequential convex programming.

Owns: `solve_scp`, one candidate duration solved by the attitude QP (`_attitude_qp`) and a
sequence of translation QPs (`_TranslationScp`) until the labels, the facets and the cost
settle, and the SCP's own numbers (the slack penalties, the polygons' facets, the chord margin).
Does not own: the problem data it shares with the NLP (`planar_approach_problem`), the config,
the result and the duration search (`planar_approach`), the joint NLP (`planar_approach_nlp`,
which starts from this method's answer), the checker (`planar_approach_check`).

Method: sequential convex programming on MathematicalProgram with Clarabel. The cost and the
dynamics are separable in translation and rotation, and only the wrench limits (8) and the
heading condition of State II couple them (through theta in the body-frame rotation and through
the torque's share of the planar_8 set). So the attitude (theta, omega, tau) is
a QP (its cost terms, eq. 6, eq. 7, |tau| <= max_torque_Nm, and |theta_k - theta_face,k| <=
the tolerance plus an L1-penalised slack at the knots of the samples that want State II),
re-solved whenever that set of samples changes (`solve_scp`); with theta_k and tau_k known,
(8) is linear in the world force, and the translation is solved by a sequence of QPs. In
each, every KOS piece (a disc, a half-disc, a half-ellipse; circumscribed polygons of 48
facets per half, at most 0.25 mm larger) is replaced, for every pair of consecutive samples,
by the facet half-plane that the previous iterate satisfies best at both (so the chord
between them keeps out too), with `_CHORD_MARGIN_M` (0.2 mm) to spare for the bend of the
straight world segment in the turning target frame; each such half-plane is disjoint from its
piece, so the QP is a convex restriction, its solution is KOS-feasible, and the previous
iterate stays feasible unless the attitude or the labels changed. Keep-out rows carry one
slack per sample with an L1 penalty (1e4 per m), which makes a start inside the zone or a
guess that cannot be flown recoverable; a converged answer with slack left is reported
INFEASIBLE. Stops when labels and facets are unchanged and the (penalised) cost changed less
than `scp_tolerance` (relative); not settled after `max_iterations` QPs is ITERATION_LIMIT.
The decomposition can lose optimality where (8) is active and where State II is wanted: the
attitude QP does not know which way, or how hard, the translation will push (the body-frame
rotation of the force limits and the torque's share of the planar_8 set), nor how much the
translation would gain by an earlier State II; the checker verifies (8) and the KOS on the
result either way, and "ipopt"/"snopt" (`planar_approach_nlp`) polish the joint problem (with
the State II labels, and so the heading bounds, of their start).
"""

import math

import numpy as np
import scipy.sparse as sp
from pydrake.solvers import ClarabelSolver, MathematicalProgram

from rpod.models import planar_approach as pa
from rpod.planners import planar_approach_problem as problem
from rpod.planners.planar_approach_problem import PlanarPlanStatus

_SLACK_PENALTY = 1e4
"""L1 weight of the keep-out slacks (cost per metre of violation at one sample)."""
_GOAL_PENALTY = 1e3
"""L1 weight of the goal constraints' slacks (per m and per m/s; `goal_constraint`): exact where
the goal can be reached (645 of the 646 Case Study 1 plans at omega <= 0.5 rad/s end within
1e-10 m of it, benchmarks/results/planar_case1_study.md), and below the keep-out's, so a
duration that cannot reach the goal keeps out of the zone and misses the goal instead."""
_SLACK_TOLERANCE_M = 1e-6
"""Slack left at convergence above which the KOS is reported unsatisfiable."""
_ACCUMULATE_AFTER = 8
"""SCP: from this iteration on, the attitude's alignment set only grows (`solve_scp`)."""
_FACETS_PER_HALF = 48
"""Facets per half-shape of the circumscribed KOS polygons (0.25 mm on r_safe = 0.45 m)."""
_CHORD_MARGIN_M = 2e-4
"""SCP: every keep-out row holds with this much to spare. Between two samples the chaser
moves on a straight line in W, which the turning target frame bends: off the chord in T by at
most (dtheta^2 / 8) (|p| + 2 |v| / |omega_t|) for a turn dtheta between the samples (<= 0.02
rad with the automatic sampling: 5e-5 (|p| + 2 |v| / |omega_t|), 0.1 mm at 0.7 m and 0.5 m/s
per rad/s); the margin keeps that bend out of the pieces and inside the switching region."""


# ------------------------------------------------------------------------ SCP: the attitude


def _attitude_qp(config, x0, theta_f, N, dt, align=None):
    """Eq. 5's rotational terms under eqs. 6-7 and |tau| <= max_torque_Nm: (theta, omega, tau)
    or None, with Clarabel's word.

    align = (knots (N + 1,) bool, face heading (N + 1,)): at those knots |theta - face| <=
    alignment_tolerance_rad (shrunk by 1e-3) + sigma, sigma >= 0 with an L1 penalty
    (_SLACK_PENALTY per rad): the attitude turns onto the docking face where the translation
    wants State II, as far as the torque allows; where it cannot, sigma > 0 and the samples
    there stay State I (`problem.labels`).
    """
    prog = MathematicalProgram()
    th = prog.NewContinuousVariables(N + 1, "theta")
    w = prog.NewContinuousVariables(N + 1, "omega")
    tau = prog.NewContinuousVariables(N, "tau")
    prog.AddBoundingBoxConstraint([x0[2], x0[5]], [x0[2], x0[5]], [th[0], w[0]])
    prog.AddBoundingBoxConstraint(theta_f, theta_f, th[N])
    prog.AddBoundingBoxConstraint(-config.max_torque_Nm, config.max_torque_Nm, tau)
    eye = sp.eye(N + 1, format="csr")
    shift = (eye[1:] - eye[:-1]).tocsc()  # x_k+1 - x_k
    pick = eye[:-1].tocsc()
    I_N = sp.eye(N, format="csc")
    A = sp.bmat(
        [[shift, -dt * pick, None], [None, shift, -dt / config.chaser_inertia_kg_m2 * I_N]],
        format="csc",
    )
    prog.AddLinearEqualityConstraint(A, np.zeros(2 * N), np.concatenate([th, w, tau]))
    Q = np.diag([config.chaser_inertia_kg_m2 * dt, 2.0 * config.w_u * dt])
    for k in range(N):
        prog.AddQuadraticCost(Q, np.zeros(2), [w[k], tau[k]], is_convex=True)
    if align is not None and np.any(align[0]):
        knots = np.flatnonzero(align[0])
        face = align[1][knots]
        sigma = prog.NewContinuousVariables(len(knots), "sigma")
        prog.AddBoundingBoxConstraint(0.0, np.inf, sigma)
        bound = config.geometry.alignment_tolerance_rad * (1.0 - 10.0 * problem.REGION_SHRINK)
        pick = sp.csr_matrix(
            (np.ones(len(knots)), (np.arange(len(knots)), knots)), shape=(len(knots), N + 1)
        )
        eye = sp.eye(len(knots), format="csr")
        A = sp.bmat([[pick, -eye], [pick, eye]], format="csc")
        lower = np.concatenate([np.full(len(knots), -np.inf), face - bound])
        upper = np.concatenate([face + bound, np.full(len(knots), np.inf)])
        prog.AddLinearConstraint(A, lower, upper, np.concatenate([th, sigma]))
        prog.AddLinearCost(_SLACK_PENALTY * np.ones(len(knots)), 0.0, sigma)
    result = ClarabelSolver().Solve(prog)
    word = problem.solver_word(result)
    if not result.is_success():
        return None, word
    return (result.GetSolution(th), result.GetSolution(w), result.GetSolution(tau)), word


# --------------------------------------------------------------------- SCP: the translation


class _TranslationScp:
    """The translation QPs of one candidate (module docstring)."""

    def __init__(self, config, x0, N, dt, theta, tau, samples):
        self.config = config
        self.geometry = config.geometry
        self.N, self.dt, self.samples = N, dt, samples
        m = config.chaser_mass_kg
        prog = self.prog = MathematicalProgram()
        self.P = prog.NewContinuousVariables(N + 1, 2, "p")
        self.V = prog.NewContinuousVariables(N + 1, 2, "v")
        self.F = prog.NewContinuousVariables(N, 2, "F")
        self.S = prog.NewContinuousVariables(samples.size, "slack")
        prog.AddBoundingBoxConstraint(x0[[0, 1, 3, 4]], x0[[0, 1, 3, 4]], [*self.P[0], *self.V[0]])
        prog.AddBoundingBoxConstraint(0.0, np.inf, self.S)
        # Eq. 7 on (p, v): p_k+1 - p_k - dt v_k = 0, v_k+1 - v_k - dt F_k / m = 0.
        eye = sp.eye(2 * (N + 1), format="csr")
        shift = (eye[2:] - eye[:-2]).tocsc()
        pick = eye[:-2].tocsc()
        I_F = sp.eye(2 * N, format="csc")
        A = sp.bmat([[shift, -dt * pick, None], [None, shift, -dt / m * I_F]], format="csc")
        variables = np.concatenate([self.P.ravel(), self.V.ravel(), self.F.ravel()])
        prog.AddLinearEqualityConstraint(A, np.zeros(4 * N), variables)
        # Eq. 8 at the known attitude and torque (`set_attitude`).
        A, lb = self._force_rows(theta, tau)
        self.force_limits = prog.AddLinearConstraint(A, lb, -lb, self.F.ravel())
        # Eq. 5: kinetic energy and wrench per step, the goal term, the slack penalty.
        Q = np.diag([m * dt, m * dt, 2.0 * config.w_u * dt, 2.0 * config.w_u * dt])
        for k in range(N):
            prog.AddQuadraticCost(Q, np.zeros(4), [*self.V[k], *self.F[k]], is_convex=True)
        prog.AddQuadraticErrorCost(config.w_goal * np.eye(2), config.goal_position, self.P[N])
        if config.w_terminal_velocity > 0.0:  # (5'): w_v |v_N - omega_t z x p_N|^2
            M = problem.relative_velocity_map(config.omega_target_rad_s)
            prog.AddQuadraticCost(
                2.0 * config.w_terminal_velocity * M.T @ M,
                np.zeros(4),
                [*self.P[N], *self.V[N]],
                is_convex=True,
            )
        prog.AddLinearCost(_SLACK_PENALTY * np.ones(samples.size), 0.0, self.S)
        if config.goal_constraint:  # p_N = p_goal, v_N = omega_t z x p_N, exact L1 penalties
            A_goal, b_goal = problem.goal_rows(config)
            G = prog.NewContinuousVariables(4, "goal_slack")
            eye = np.eye(4)
            prog.AddLinearConstraint(
                np.block([[A_goal, -eye], [A_goal, eye]]),
                np.concatenate([np.full(4, -np.inf), b_goal]),
                np.concatenate([b_goal, np.full(4, np.inf)]),
                np.concatenate([self.P[N], self.V[N], G]),
            )
            prog.AddLinearCost(_GOAL_PENALTY * np.ones(4), 0.0, G)
        self.keepout = prog.AddLinearConstraint(
            sp.csc_matrix((1, 2 * (N + 1) + samples.size)),
            [-np.inf],
            [np.inf],
            np.concatenate([self.P.ravel(), self.S]),
        )
        self.pieces = {
            state: self.geometry.pieces(state, _FACETS_PER_HALF)
            for state in (pa.STATE_I, pa.STATE_II)
        }
        alpha = self.geometry.switch_angle_rad * (1.0 - problem.REGION_SHRINK)
        distance_normals, distance_offset = problem.distance_facets(self.geometry)
        # State II's own conditions as pieces of one "facet" each that must all hold:
        # n . p_T >= offset (cone sides; -(inscribed polygon facets)).
        self.region_rows = (
            np.vstack(
                [[math.sin(alpha), -math.cos(alpha)], [math.sin(alpha), math.cos(alpha)]]
                + [-distance_normals]
            ),
            np.concatenate([[0.0, 0.0], -np.full(len(distance_normals), distance_offset)]),
        )

    def _force_rows(self, theta: np.ndarray, tau: np.ndarray):
        """Eq. 8 as rows of R(theta_k)^T F_k (and the planar_8 cut's sums) and their bound."""
        config, N = self.config, self.N
        c, s = np.cos(theta[:N]), np.sin(theta[:N])
        blocks = [np.array([[ck, sk], [-sk, ck]]) for ck, sk in zip(c, s)]
        fmax = config.max_force_N
        lower = [np.full(2 * N, -fmax)]
        rows = [sp.block_diag(blocks, format="csr")]
        if config.wrench_limit == "planar_8":
            kappa = 2.0 * fmax / config.max_torque_Nm
            room = np.maximum(2.0 * fmax - kappa * np.abs(tau), 0.0)
            sums = [np.array([[ck - sk, sk + ck], [ck + sk, sk - ck]]) for ck, sk in zip(c, s)]
            rows.append(sp.block_diag(sums, format="csr"))
            lower.append(-np.repeat(room, 2))
        return sp.vstack(rows).tocsc(), np.concatenate(lower)

    def set_attitude(self, theta: np.ndarray, tau: np.ndarray) -> None:
        """Reloads eq. 8's rows for a new attitude plan (theta, tau)."""
        A, lb = self._force_rows(theta, tau)
        self.force_limits.evaluator().UpdateCoefficients(A, lb, -lb)

    def update_keepout(self, P_bar: np.ndarray, labels: np.ndarray) -> tuple:
        """Chooses the facets at P_bar and loads the keep-out rows; returns the choice.

        Per pair of consecutive samples (a segment) and per piece of the segment's zone (State
        II's when both samples are labelled II, else State I's, which contains it), one facet
        that both samples must satisfy: the one P_bar satisfies best at the worse of the two.
        A half-plane is convex, so the chord between the two samples in T keeps out of the
        piece too: a path cannot cut a piece's corner between samples that chose different
        facets. Each State II sample also keeps the switching region's rows.
        """
        samples, N = self.samples, self.N
        p_T = samples.to_target(samples.positions(P_bar))
        c_all, s_all = np.cos(samples.theta_t), np.sin(samples.theta_t)
        row_j, row_n, row_b, choice = [], [], [], []
        first = np.arange(max(samples.size - 1, 1))
        second = np.minimum(first + 1, samples.size - 1)
        both_ii = (labels[first] == pa.STATE_II) & (labels[second] == pa.STATE_II)
        segment_state = np.where(both_ii, pa.STATE_II, pa.STATE_I)
        for state in (pa.STATE_I, pa.STATE_II):
            a, b = first[segment_state == state], second[segment_state == state]
            if not a.size:
                continue
            for normals, offsets in self.pieces[state]:
                signed = np.minimum(p_T[a] @ normals.T, p_T[b] @ normals.T) - offsets
                best = np.argmax(signed, axis=1)
                choice.append(best)
                row_j += [a, b]
                row_n += [normals[best], normals[best]]
                row_b += [offsets[best], offsets[best]]
        j = np.flatnonzero(labels == pa.STATE_II)
        if j.size:
            normals, offsets = self.region_rows
            for i in range(len(offsets)):
                row_j.append(j)
                row_n.append(np.broadcast_to(normals[i], (j.size, 2)))
                row_b.append(np.full(j.size, offsets[i]))
        j = np.concatenate(row_j)
        n_T = np.vstack(row_n)
        b = np.concatenate(row_b) + _CHORD_MARGIN_M
        c, s = c_all[j], s_all[j]
        n_W = np.column_stack([c * n_T[:, 0] - s * n_T[:, 1], s * n_T[:, 0] + c * n_T[:, 1]])
        k, w = samples.k[j], samples.s[j]
        rows = np.arange(len(j))
        r = np.repeat(rows, 5)
        cols = np.column_stack([2 * k, 2 * k + 1, 2 * k + 2, 2 * k + 3, 2 * (N + 1) + j]).ravel()
        vals = np.column_stack(
            [
                (1 - w) * n_W[:, 0],
                (1 - w) * n_W[:, 1],
                w * n_W[:, 0],
                w * n_W[:, 1],
                np.ones(len(j)),
            ]
        ).ravel()
        A = sp.csc_matrix((vals, (r, cols)), shape=(len(j), 2 * (N + 1) + samples.size))
        self.keepout.evaluator().UpdateCoefficients(A, b, np.full(len(b), np.inf))
        return tuple(np.concatenate(choice).tolist())

    def solve(self):
        """One QP: (P, V, F, slack) or None, and Clarabel's word."""
        result = ClarabelSolver().Solve(self.prog)
        word = problem.solver_word(result)
        if not result.is_success():
            return None, word
        get = result.GetSolution
        return (get(self.P), get(self.V), get(self.F), get(self.S)), word


def solve_scp(config, x0, duration_s, guess):
    """The "scp" method for one duration: (status, word, iterations, X, U).

    Each iteration: the samples that want State II (`problem.wanted`, from the last translation)
    -> the attitude QP, asked to face the docking face at their knots (re-solved only when
    that set changed) -> labels: State II where wanted and aligned -> a translation QP at that
    attitude. From iteration _ACCUMULATE_AFTER on, the set the attitude aligns for only grows
    (the union of the wanted sets since): a sample at the edge of the final approach can
    otherwise toggle the attitude and the translation in a cycle. Settled when that set, the
    labels and the facets are unchanged and the cost moved less than scp_tolerance: the last
    translation and attitude were then solved with the same labels.
    """
    N, dt = problem.grid(config, duration_s)
    t = np.arange(N + 1) * dt
    theta_f = pa.chaser_final_attitude(config.theta_approach_rad, x0[2])
    face = problem.face_heading(config, t, theta_f)
    samples = problem.samples(config, N, dt)
    geometry = config.geometry
    P_bar, theta_bar = guess[0][:, :2], guess[0][:, 2]
    wanted = problem.wanted(geometry, samples.to_target(samples.positions(P_bar)))
    aligning = wanted  # the samples the attitude QP faces the docking face for

    def attitude_for(aligning, theta_bar):
        if not config.state_ii_heading:  # the paper's switch: no heading asked of State II
            return _attitude_qp(config, x0, theta_f, N, dt)
        align = problem.alignment_targets(samples, aligning, theta_bar, face, N)
        return _attitude_qp(config, x0, theta_f, N, dt, align)

    attitude, word = attitude_for(aligning, theta_bar)
    if attitude is None:
        return PlanarPlanStatus.INFEASIBLE, f"attitude QP: {word}", 0, None, None
    theta, omega, tau = attitude
    labels = problem.labels(wanted, problem.aligned_samples(config, samples, theta, t))
    scp = _TranslationScp(config, x0, N, dt, theta, tau, samples)
    choice, cost, status = None, math.inf, PlanarPlanStatus.ITERATION_LIMIT
    iterations = 0
    for iterations in range(1, config.max_iterations + 1):
        new_choice = scp.update_keepout(P_bar, labels)
        solution, word = scp.solve()
        if solution is None:
            return PlanarPlanStatus.SOLVER_FAILED, f"translation QP: {word}", iterations, None, None
        P, V, F, slack = solution
        X = np.column_stack([P, theta, V, omega])
        U = np.column_stack([F, tau])
        new_cost = sum(problem.cost_terms(config, X, U, dt).values()) + _SLACK_PENALTY * slack.sum()
        new_wanted = problem.wanted(geometry, samples.to_target(samples.positions(P)))
        new_aligning = new_wanted | aligning if iterations >= _ACCUMULATE_AFTER else new_wanted
        same_aligning = np.array_equal(new_aligning, aligning)
        if not same_aligning:
            attitude, attitude_word = attitude_for(new_aligning, theta)
            if attitude is None:
                word = f"attitude QP: {attitude_word}"
                return PlanarPlanStatus.INFEASIBLE, word, iterations, None, None
            theta, omega, tau = attitude
            scp.set_attitude(theta, tau)
        new_labels = problem.labels(new_wanted, problem.aligned_samples(config, samples, theta, t))
        settled = (
            same_aligning
            and new_choice == choice
            and np.array_equal(new_labels, labels)
            and abs(new_cost - cost) <= config.scp_tolerance * (1.0 + abs(new_cost))
        )
        choice, cost, labels, aligning, P_bar = new_choice, new_cost, new_labels, new_aligning, P
        if settled:
            status = PlanarPlanStatus.SUCCESS
            break
    word = f"{word}; SCP {'converged' if status == PlanarPlanStatus.SUCCESS else 'stopped'}"
    if status == PlanarPlanStatus.SUCCESS and slack.max() > _SLACK_TOLERANCE_M:
        status = PlanarPlanStatus.INFEASIBLE
        word += f" with keep-out slack {slack.max():.3g} m left (the KOS cannot be kept)"
    return status, word, iterations, X, U
