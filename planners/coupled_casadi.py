"""Paper 001's NLP (22) in CasADi, for IPOPT with exact second derivatives.

Owns `CasadiTranscription`: the same multiple-shooting NLP as `rpod.planners.coupled_nmpc`
(RK4 defects with `rk4_substeps` steps per interval and the Newton-Schulz return of R_TC onto
SO(3), eqs. 16-18 and the cost of eqs. 20-21) built as a CasADi expression graph, and its IPOPT
solve. Does not own: the model (rpod.models.coupled_relative, called as it is on CasADi scalars),
the settings, result type or statuses (rpod.planners.coupled_nmpc), the receding horizon.

Why CasADi: IPOPT converges in few iterations on this problem only with the Hessian of the
Lagrangian, and Drake's IpoptSolver hands IPOPT none (it runs a limited-memory quasi-Newton
approximation, which does not converge at the paper's T = 480 s: rpod.planners.coupled_nmpc).
CasADi differentiates the expression graph twice by algorithmic differentiation and drives the
IPOPT it ships, the solver and front end paper 001 used (Sec. IV). The equations are not
rewritten: `coupled_relative.dynamics` and `stage_cost` are scalar-generic and are evaluated once
on numpy object arrays of CasADi SX scalars to build the graph (tested equal to the float model).

NLP variables, in this order: the nodes' 21 NLP states (N + 1 rows), the inputs (N rows of 24),
the LOS slacks (N + 1 rows of 4). Parameters: the target's reference nodes (N + 1 rows of 18),
propagated from x0 outside the NLP as in the MathematicalProgram transcription. x_0 = x0 enters as
equal bounds on the first node (IPOPT removes fixed variables).
"""

import hashlib
import logging
import os
import pathlib
import shutil
import stat
import subprocess
import tempfile
import time

import casadi as ca
import numpy as np

from rpod.models import coupled_relative as cr
from rpod.models.gimbal import gimbal_constraint_matrix
from rpod.planners import coupled_shooting as cs

# CasADi 3.8 warns once when a numpy function meets a CasADi value; -1 keeps the behaviour the
# model code relies on (numpy's concatenate of SX entries returns an SX) without the warning.
if hasattr(ca.GlobalOptions, "setNumpyMode"):
    ca.GlobalOptions.setNumpyMode(-1)

_N_X = cr.PAPER_STATE_SIZE
_N_T = cr.STATE_SIZE - cr.PAPER_STATE_SIZE

IPOPT_DEFAULTS = {
    "print_level": 0,
    "sb": "yes",  # no banner: `rpod run` prints one line
    "tol": 1e-6,
    "max_iter": 300,
    "mu_strategy": "adaptive",
}
"""IPOPT options of every solve (`CasadiTranscription`'s ipopt_options override them). The
adaptive barrier update with its default oracle: in the Sec. IV closed loop the probing and LOQO
oracles hit 100 iterations at every step, and the monotone update at every step with mu_init
1e-4 and at two steps with 1e-2 (then ~18 a step, against ~12)."""

IPOPT_WARM_START = {
    "warm_start_init_point": "yes",
    "warm_start_bound_push": 1e-6,
    "warm_start_bound_frac": 1e-6,
    "warm_start_slack_bound_push": 1e-6,
    "warm_start_slack_bound_frac": 1e-6,
    "warm_start_mult_bound_push": 1e-6,
}
"""Added when a solve starts from a previous solution and its multipliers: IPOPT keeps the guess
instead of pushing it 1e-2 into the interior. Sec. IV closed loop: ~12 iterations per solve
instead of ~23 (with 2 of 34 solves at 100)."""


def _entries(v) -> np.ndarray:
    """An SX column as a numpy object array of scalar SX (what the generic model code takes)."""
    return np.array([v[i] for i in range(v.shape[0])], dtype=object)


def _column(entries) -> ca.SX:
    """The inverse of `_entries`: a numpy object array (or an SX) as an SX column."""
    if isinstance(entries, ca.SX):
        return ca.reshape(entries, -1, 1)
    return ca.vertcat(*np.asarray(entries, dtype=object).reshape(-1).tolist())


def model_functions(params: cr.CoupledRelativeParams, weights: cr.CoupledNmpcWeights):
    """CasADi functions f(x, u) -> x_dot (39) and l(x, u) -> F (eq. 20) of the model."""
    x = ca.SX.sym("x", cr.STATE_SIZE)
    u = ca.SX.sym("u", cr.INPUT_SIZE)
    f = _column(cr.dynamics(_entries(x), _entries(u), params))
    l_cost = _column(np.atleast_1d(cr.stage_cost(_entries(x), _entries(u), weights, params)))
    return ca.Function("f", [x, u], [f]), ca.Function("l", [x, u], [l_cost])


def interval_function(
    params: cr.CoupledRelativeParams,
    weights: cr.CoupledNmpcWeights,
    interval_s: float,
    substeps: int,
) -> ca.Function:
    """Phi_w(x_k[:21], wrench_k, x_k[21:]) -> (x_k+1[:21], c_k - T_s u^T W_f u): one interval of
    `coupled_nmpc.rk4_interval` as a graph, with the input through its wrench [tau_C; f_C].

    The inputs act on the dynamics only through the wrench of eqs. 11-12 (w = M u, M (6, 24)),
    and on the stage cost (eq. 20) through it and the term u^T W_f u, constant over an interval
    (so T_s u^T W_f u, exactly, in c_k). Evaluating the model at u* = M^+ w (M M^+ = I) and
    leaving that term out keeps every derivative in 21 + 6 directions instead of 21 + 24, which
    makes the Hessian ~2x cheaper (`interval_derivatives`). The same RK4 steps and the same
    Newton-Schulz return of R_TC onto SO(3) (`coupled_shooting.polar_newton_schulz`, on the
    object array of SX entries) as the MathematicalProgram transcription.
    """
    f, l_cost = model_functions(params, weights)
    x_nlp = ca.SX.sym("x", _N_X)
    wrench = ca.SX.sym("wrench", 6)
    x_target = ca.SX.sym("x_target", _N_T)
    u = ca.mtimes(ca.DM(np.linalg.pinv(cr._force_to_wrench_matrix(params))), wrench)
    x = ca.vertcat(x_nlp, x_target)
    dt = interval_s / substeps
    q = 0.0
    for _ in range(substeps):
        k1, l1 = f(x, u), l_cost(x, u)
        x2 = x + (0.5 * dt) * k1
        k2, l2 = f(x2, u), l_cost(x2, u)
        x3 = x + (0.5 * dt) * k2
        k3, l3 = f(x3, u), l_cost(x3, u)
        x4 = x + dt * k3
        k4, l4 = f(x4, u), l_cost(x4, u)
        x = x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        q = q + (dt / 6.0) * (l1 + 2.0 * l2 + 2.0 * l3 + l4)
    q = q - interval_s * ca.mtimes([u.T, ca.DM(np.asarray(weights.W_f, dtype=float)), u])
    R_TC = cs.polar_newton_schulz(_entries(x[cr.R_TC_SLICE]).reshape(3, 3))
    x_end = ca.vertcat(_column(R_TC), x[cr.R_TC_SLICE.stop : _N_X])
    return ca.Function("Phi_w", [x_nlp, wrench, x_target], [x_end, q])


def interval_derivatives(Phi_w: ca.Function) -> tuple[ca.Function, ca.Function, ca.Function]:
    """One interval's first and second derivatives in z = [x_k[:21], wrench_k] (27):

    - ``jac(x, wrench, x_target) -> d x_end / dz (21, 27)``;
    - ``grad(x, wrench, x_target) -> (q_w, d q_w / dz (1, 27))``;
    - ``hess(x, wrench, x_target, lam (21), lam_f) -> d2/dz2 (lam_f q_w - lam . x_end)`` (27,
      27), the interval's block of the Hessian of the Lagrangian in z (its defect is
      x_k+1 - x_end); the chain rule to u and the u^T W_f u term are the assembly's.
    """
    x = ca.SX.sym("x", _N_X)
    wrench = ca.SX.sym("wrench", 6)
    x_target = ca.SX.sym("x_target", _N_T)
    lam = ca.SX.sym("lam", _N_X)
    lam_f = ca.SX.sym("lam_f")
    z = ca.vertcat(x, wrench)
    x_end, q = Phi_w(x, wrench, x_target)
    jac = ca.Function("coupled_interval_jac", [x, wrench, x_target], [ca.jacobian(x_end, z)])
    grad = ca.Function("coupled_interval_grad", [x, wrench, x_target], [q, ca.jacobian(q, z)])
    hessian, _ = ca.hessian(lam_f * q - ca.dot(lam, x_end), z)
    hess = ca.Function("coupled_interval_hess", [x, wrench, x_target, lam, lam_f], [hessian])
    return jac, grad, hess


def cache_dir() -> pathlib.Path:
    """Where compiled derivative code is kept: $RPOD_CACHE_DIR/casadi or ~/.cache/rpod/casadi."""
    root = os.environ.get("RPOD_CACHE_DIR") or os.path.join(pathlib.Path.home(), ".cache", "rpod")
    return pathlib.Path(root) / "casadi"


_LOG = logging.getLogger("rpod.compile")
"""Says when a one-time compile starts (rpod run shows it: the run is silent meanwhile), and
warns when the cache cannot be used (the derivatives are then evaluated by CasADi's virtual
machine: the same numbers, ~6x slower)."""

COMPILE_FLAGS = ("-O1", "-fPIC", "-shared")
"""C compiler flags for the derivative code. Measured on one interval's Hessian (2 shared
cores): -O1 compiles in ~28 s and runs it in ~0.17 ms, -O2 in ~79 s and ~0.20 ms; -O0 (on the
earlier 45-direction Hessian) in ~18 s and ~4 ms."""

_VIRTUAL_MACHINE = "derivatives evaluated by CasADi's virtual machine"
_CHECKSUM_SUFFIX = ".sha256"


class CacheError(Exception):
    """The derivative cache cannot be trusted or used; the message says why."""


def private_cache_dir() -> pathlib.Path:
    """cache_dir(), made if missing (mode 0o700) and checked: a folder of this user that no
    other user can write. CacheError otherwise; OSError when it cannot be made or read.

    A library in the cache is loaded into the process (dlopen runs its code), so a cache another
    user can write is refused, not used. A folder of this user's that others can read (an older
    rpod made it 0o755) is made private.
    """
    folder = cache_dir()
    folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    info = os.stat(folder)
    if not stat.S_ISDIR(info.st_mode):
        raise CacheError("it is not a folder")
    if info.st_uid != os.geteuid():
        raise CacheError(f"it belongs to another user (uid {info.st_uid})")
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        raise CacheError(f"other users can write to it (mode {stat.S_IMODE(info.st_mode):o})")
    if stat.S_IMODE(info.st_mode) & 0o077:
        os.chmod(folder, 0o700)
    return folder


def _sha256(path: pathlib.Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def checksum_path(library: pathlib.Path) -> pathlib.Path:
    """The file beside a compiled library that holds its SHA-256 (hex), written after its
    compile; the library is loaded only when its bytes match it."""
    return library.with_name(library.name + _CHECKSUM_SUFFIX)


def verified(library: pathlib.Path) -> bool:
    """True when the library's bytes match the checksum written beside it; False when it is
    missing, has no checksum (not rpod's compile: a file put there), or differs from it
    (truncated or corrupt). A truncated library, loaded, kills the process with SIGBUS."""
    try:
        with open(checksum_path(library)) as handle:
            expected = handle.read(100).strip()
        return _sha256(library) == expected
    except FileNotFoundError:
        return False


def _build(compiler: str, source: bytes, name: str, library: pathlib.Path) -> str | None:
    """Compiles source into library (and its checksum) in its folder; None, or why it failed.

    The compiler runs in a temporary folder beside the library, on relative file names, so the
    same source gives the same bytes (no temporary path in the library); the checksum, then the
    library, are moved into place by rename, so parallel workers never load half a file.
    """
    with tempfile.TemporaryDirectory(dir=library.parent) as folder:
        pathlib.Path(folder, f"{name}.c").write_bytes(source)
        run = subprocess.run(
            [compiler, *COMPILE_FLAGS, f"{name}.c", "-o", library.name, "-lm"],
            cwd=folder,
            capture_output=True,
            text=True,
            check=False,
        )
        if run.returncode != 0:
            return (run.stderr.strip().splitlines() or ["?"])[-1]
        built = pathlib.Path(folder, library.name)
        checksum = pathlib.Path(folder, checksum_path(library).name)
        checksum.write_text(_sha256(built) + "\n")
        os.replace(checksum, checksum_path(library))
        os.replace(built, library)
    return None


def _remove(library: pathlib.Path) -> None:
    for path in (library, checksum_path(library)):
        try:
            path.unlink()
        except FileNotFoundError:
            pass


def compile_functions(functions: list[ca.Function], name: str) -> tuple[list, str]:
    """The functions as C (CasADi's code generator) compiled by the system C compiler, cached.

    The cache key is the hash of the generated C source and the flags, so a changed model or
    weight makes new code, never a stale one. Returns (functions, message): the compiled
    `casadi.external` functions, or the given ones (CasADi's virtual machine, the same numbers,
    ~6x slower) and why, when no C compiler is found or compiling fails.

    The cache is trusted only so far (private_cache_dir, verified): a library is loaded only
    when its SHA-256 matches the one written beside it after its compile. One that does not (a
    truncated or corrupt file, or one put there under the expected name) is removed and
    compiled again; when that is impossible, or the cache folder cannot be used at all (a file
    in its place, not writable, another user's), the virtual machine is used, with one warning.
    """
    compiler = shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")
    if compiler is None:
        return functions, f"no C compiler found: {_VIRTUAL_MACHINE}"
    with tempfile.TemporaryDirectory() as folder:
        generator = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        for function in functions:
            generator.add(function)
        generator.generate(folder + os.sep)
        source = pathlib.Path(folder, f"{name}.c").read_bytes()
    key = hashlib.sha256(source + " ".join(COMPILE_FLAGS).encode()).hexdigest()[:20]
    library = cache_dir() / f"{name}_{key}.so"
    try:
        library = private_cache_dir() / library.name
        if os.path.lexists(library) and not verified(library):
            _remove(library)
            _LOG.warning(
                "the cached %s did not match its checksum (truncated, corrupt, or not written "
                "by rpod): removed, compiled again",
                library,
            )
        if not library.exists():
            _LOG.info(
                "compiling the NMPC's derivatives to C, once (~30-80 s; cached in %s)",
                library.parent,
            )
            failure = _build(compiler, source, name, library)
            if failure is not None:
                return functions, f"compiling failed ({failure}): CasADi's virtual machine used"
            if not verified(library):
                raise CacheError("the library just compiled does not match its checksum")
        compiled = [ca.external(function.name(), str(library)) for function in functions]
    except (OSError, CacheError, RuntimeError) as error:  # RuntimeError: CasADi cannot load it
        why = error.strerror if isinstance(error, OSError) and error.strerror else str(error)
        why = " ".join(why.split())[:200]
        _LOG.warning(
            "the derivative cache %s cannot be used (%s): %s (the same numbers, ~6x slower)",
            library.parent,
            why,
            _VIRTUAL_MACHINE,
        )
        return functions, f"cache {library.parent} not used ({why}): {_VIRTUAL_MACHINE}"
    return compiled, f"compiled derivatives {library}"


class CasadiTranscription:
    """The NLP of eq. 22 as a CasADi graph, solved by IPOPT with exact Hessians.

    The objective's gradient, the constraint Jacobian and the Hessian of the Lagrangian are
    assembled from each interval's own derivatives (`interval_derivatives`) in 21 + 6
    directions, chained to the 24 inputs through M, and handed to IPOPT (CasADi's nlpsol
    options grad_f, jac_g, hess_lag); with `compile` (and a C compiler) the three are compiled
    to C. Why (measured per Hessian call, 2 shared cores): CasADi's own Hessian of the whole
    graph took 12-13 ms on its virtual machine, the assembled one 7.5 ms there and 1.6 ms
    compiled (8 intervals x 0.2 ms); CasADi's own functions of the whole NLP, generated as C,
    took 10 min to compile and then 18 ms a Hessian call.
    Tested equal to CasADi's own derivatives of the whole graph. The linear constraints' and
    the squared magnitude's derivatives come from their expressions. The gradient is returned
    dense: CasADi 3.8's IPOPT interface reads grad_f's nonzeros as a dense vector, and a
    sparse one (the terminal node's 15 entries without cost) silently shifted it.

    Args:
        problem: The NLP's data (rpod.planners.coupled_shooting.ShootingProblem).
        ipopt_options: IPOPT options (names as IPOPT's), on top of `IPOPT_DEFAULTS`.
        compile: Compile the interval derivatives to C (`compile_functions`).
    """

    def __init__(
        self,
        problem: cs.ShootingProblem,
        ipopt_options: dict | None = None,
        compile: bool = False,
    ):
        params, weights, A_p = problem.params, problem.weights, problem.A_p
        interval_s, substeps = problem.interval_s, problem.substeps
        los_slack_weight = problem.los_slack_weight
        max_relative_rate_rad_s = problem.max_relative_rate_rad_s
        self.N = N = int(problem.intervals)
        m, n_p = cr.INPUT_SIZE, A_p.shape[0]
        Phi_w = interval_function(params, weights, interval_s, substeps)
        jac, grad, hess = interval_derivatives(Phi_w)
        M = ca.DM(cr._force_to_wrench_matrix(params))
        W_f = ca.DM(np.asarray(weights.W_f, dtype=float))
        self._force_cost = (interval_s, np.asarray(weights.W_f, dtype=float))

        n_x, n_u, n_s = _N_X * (N + 1), m * N, n_p * (N + 1)
        self._sizes = (n_x, n_u, n_s)
        n_w = n_x + n_u + n_s
        w = ca.SX.sym("w", n_w)
        P = ca.SX.sym("p", _N_T * (N + 1))  # parameters: the target's reference nodes
        X = ca.reshape(w[:n_x], _N_X, N + 1)
        U = ca.reshape(w[n_x : n_x + n_u], m, N)
        S = ca.reshape(w[n_x + n_u :], n_p, N + 1)
        T = ca.reshape(P, _N_T, N + 1)

        # Constraints: defects, then eq. 16 (b = 0), eq. 17 squared, eq. 18 softened.
        A_g, _ = gimbal_constraint_matrix(params.layout)
        defects, stage = [], 0.0
        for k in range(N):
            x_end, c_w = Phi_w(X[:, k], ca.mtimes(M, U[:, k]), T[:, k])
            defects.append(X[:, k + 1] - x_end)
            stage = stage + c_w + interval_s * ca.mtimes([U[:, k].T, W_f, U[:, k]])  # c_k
        rest = ca.vertcat(
            *[ca.mtimes(ca.DM(A_g), U[:, k]) for k in range(N)],  # eq. 16
            *[ca.sumsqr(U[3 * j : 3 * j + 3, k]) for k in range(N) for j in range(8)],  # eq. 17
            *[ca.mtimes(ca.DM(A_p), X[cr.P_PTPC_T_SLICE, k]) - S[:, k] for k in range(N + 1)],
        )  # eq. 18
        g = ca.vertcat(*defects, rest)
        pv = ca.vertcat(X[cr.P_PTPC_T_SLICE, N], X[cr.V_PTPC_T_SLICE, N])
        P_terminal = np.asarray(weights.P, dtype=float)
        cost = (
            stage
            + ca.mtimes([pv.T, ca.DM(P_terminal), pv])  # eq. 21
            + los_slack_weight * ca.sum1(ca.vec(S))
        )

        n_def, n_gim, n_mag = N * _N_X, N * A_g.shape[0], N * cr.THRUSTER_COUNT
        n_los = (N + 1) * n_p
        f_max = np.tile(params.layout.max_thrusts_N, N)
        self._lbg = np.concatenate([np.zeros(n_def), np.full(n_gim + n_mag + n_los, -np.inf)])
        self._ubg = np.concatenate([np.zeros(n_def + n_gim), f_max**2, np.zeros(n_los)])
        lbx, ubx = np.full(n_w, -np.inf), np.full(n_w, np.inf)
        rate_rows = np.arange(_N_X)[cr.W_TC_T_SLICE]
        for k in range(1, N + 1):
            lbx[k * _N_X + rate_rows] = -max_relative_rate_rad_s
            ubx[k * _N_X + rate_rows] = max_relative_rate_rad_s
        lbx[n_x + n_u :] = 0.0  # s >= 0
        self._lbx, self._ubx = lbx, ubx
        self._phi_map = Phi_w.map(N)
        self._wrench_matrix = np.asarray(M)
        self._g_blocks = ((N, _N_X), (N, A_g.shape[0]), (N, cr.THRUSTER_COUNT), (N + 1, n_p))
        self._x_blocks = ((N + 1, _N_X), (N, m), (N + 1, n_p))

        derivatives = self._assembled_derivatives(
            Phi_w,
            jac,
            grad,
            hess,
            ca.Function("rest", [w], [rest]),
            P_terminal,
            los_slack_weight,
            (n_def, n_gim, n_mag),
        )
        self.derivatives_message = _VIRTUAL_MACHINE
        if compile:
            derivatives, self.derivatives_message = compile_functions(derivatives, "coupled_nmpc")
        jac_g, hess_lag, grad_f = derivatives
        options = dict(IPOPT_DEFAULTS)
        options.update(ipopt_options or {})
        nlp = {"x": w, "f": cost, "g": g, "p": P}
        self._nlp = nlp
        self._solvers = {
            warm: ca.nlpsol(
                "coupled_nmpc",
                "ipopt",
                nlp,
                {
                    "ipopt": {**options, **IPOPT_WARM_START} if warm else options,
                    "print_time": False,
                    "show_eval_warnings": False,
                    "grad_f": grad_f,
                    "jac_g": jac_g,
                    "hess_lag": hess_lag,
                },
            )
            for warm in (False, True)
        }

    def _assembled_derivatives(
        self, Phi_w, jac, grad, hess, rest, P_terminal, los_slack_weight, rows
    ):
        """[jac_g, hess_lag, grad_f] of the whole NLP from the intervals' blocks (class
        docstring).

        Signatures as CasADi's own: jac_g(x, p) -> (g, jac_g_x); hess_lag(x, p, lam_f,
        lam_g) -> triu Hessian of lam_f f + lam_g . g; grad_f(x, p) -> (f, grad_f_x).
        """
        N, (n_x, n_u, n_s) = self.N, self._sizes
        n_w = n_x + n_u + n_s
        n_def, n_gim, n_mag = rows
        m = cr.INPUT_SIZE
        w = ca.MX.sym("w", n_w)
        P = ca.MX.sym("p", _N_T * (N + 1))
        lam_f = ca.MX.sym("lam_f")
        lam_g = ca.MX.sym("lam_g", n_def + n_gim + n_mag + rest.size1_out(0) - n_gim - n_mag)
        X = ca.reshape(w[:n_x], _N_X, N + 1)
        U = ca.reshape(w[n_x : n_x + n_u], m, N)
        T = ca.reshape(P, _N_T, N + 1)

        def selector(columns):  # E (n_w, len): E[columns[a], a] = 1
            columns = np.asarray(columns)
            pattern = ca.Sparsity.triplet(
                n_w, columns.size, columns.tolist(), list(range(columns.size))
            )
            return ca.DM(pattern, 1.0)

        M = self._wrench_matrix
        E = []  # d z_k / d w, z_k = [X_k, M U_k] (27): the selector of X_k, then U_k through M
        for k in range(N):
            rows_of = np.zeros((n_w, _N_X + 6))
            rows_of[_N_X * k + np.arange(_N_X), np.arange(_N_X)] = 1.0
            rows_of[n_x + m * k : n_x + m * (k + 1), _N_X:] = M.T
            E.append(ca.sparsify(ca.DM(rows_of)))
        values, jac_rows, hess_terms, gradient_terms, cost_terms = [], [], [], [], []
        lam_def = ca.reshape(lam_g[:n_def], _N_X, N)
        for k in range(N):
            wrench = ca.mtimes(ca.DM(M), U[:, k])
            x_end, _ = Phi_w(X[:, k], wrench, T[:, k])
            values.append(X[:, k + 1] - x_end)
            next_node = selector(_N_X * (k + 1) + np.arange(_N_X)).T
            jac_rows.append(next_node - ca.mtimes(jac(X[:, k], wrench, T[:, k]), E[k].T))
            q_w, J_q = grad(X[:, k], wrench, T[:, k])
            gradient_terms.append(ca.mtimes(E[k], J_q.T))
            cost_terms.append(q_w)
            H_k = hess(X[:, k], wrench, T[:, k], lam_def[:, k], lam_f)
            hess_terms.append(ca.mtimes([E[k], H_k, E[k].T]))
        rest_value = rest(w)
        g = ca.vertcat(*values, rest_value)
        J = ca.vertcat(*jac_rows, ca.jacobian(rest_value, w))
        jac_g = ca.Function("coupled_jac_g", [w, P], [g, J], ["x", "p"], ["g", "jac_g_x"])

        interval_s, W_f = self._force_cost
        inputs = selector(n_x + np.arange(n_u))
        terminal = selector(_N_X * N + np.arange(12, 18))
        slacks = selector(n_x + n_u + np.arange(n_s))
        pv = ca.mtimes(terminal.T, w)
        force_costs = ca.sum1(ca.vec(U * ca.mtimes(ca.DM(interval_s * W_f), U)))
        f = (
            sum(cost_terms)
            + force_costs
            + ca.mtimes([pv.T, ca.DM(P_terminal), pv])
            + los_slack_weight * ca.sum1(ca.mtimes(slacks.T, w))
        )
        gradient = (
            sum(gradient_terms)
            + ca.mtimes(inputs, ca.vec(ca.mtimes(ca.DM(2.0 * interval_s * W_f), U)))
            + ca.mtimes(terminal, ca.mtimes(ca.DM(2.0 * P_terminal), pv))
            + ca.mtimes(slacks, ca.DM.ones(n_s) * los_slack_weight)
        )
        grad_f = ca.Function(  # dense: CasADi's IPOPT interface copies the gradient as dense
            "coupled_grad_f", [w, P], [f, ca.densify(gradient)], ["x", "p"], ["f", "grad_f_x"]
        )
        force_term = ca.sparsify(ca.DM(np.kron(np.eye(N), 2.0 * interval_s * W_f)))  # T_s u^T W_f u
        hess_terms.append(lam_f * ca.mtimes([inputs, force_term, inputs.T]))
        hess_terms.append(
            lam_f * ca.mtimes([terminal, ca.DM(np.triu(2.0 * P_terminal)), terminal.T])
        )
        lam_mag = lam_g[n_def + n_gim : n_def + n_gim + n_mag]
        per_entry = ca.vec(ca.repmat(lam_mag.T, 3, 1))  # each thruster's multiplier, x3
        hess_terms.append(ca.diag(ca.mtimes(inputs, 2.0 * per_entry)))  # eq. 17: 2 lam I
        H = hess_terms[0]
        for term in hess_terms[1:]:
            H = H + term
        hess_lag = ca.Function(
            "coupled_hess_lag",
            [w, P, lam_f, lam_g],
            [ca.triu(H)],
            ["x", "p", "lam_f", "lam_g"],
            ["triu_hess_gamma_x_x"],
        )
        return [jac_g, hess_lag, grad_f]

    def stage_costs(self, x_nodes: np.ndarray, u: np.ndarray, target_nodes: np.ndarray):
        """c_k, the stage cost integrated over each interval (N,), as the NLP computes it."""
        u = np.asarray(u, dtype=float)
        _, q_w = self._phi_map(
            np.asarray(x_nodes[:-1, :_N_X]).T,
            self._wrench_matrix @ u.T,
            np.asarray(target_nodes[:-1]).T,
        )
        interval_s, W_f = self._force_cost
        return np.asarray(q_w).reshape(-1) + interval_s * np.einsum("ki,ij,kj->k", u, W_f, u)

    def shift_multipliers(self, lam_x: np.ndarray, lam_g: np.ndarray):
        """(lam_x, lam_g) moved one interval on, the last repeated (as the primal warm start)."""

        def shift(values, blocks):
            out, start = [], 0
            for count, size in blocks:
                block = values[start : start + count * size].reshape(count, size)
                out.append(np.vstack([block[1:], block[-1:]]).reshape(-1))
                start += count * size
            return np.concatenate(out)

        return shift(lam_x, self._x_blocks), shift(lam_g, self._g_blocks)

    def pack(self, x_nodes: np.ndarray, u: np.ndarray, slack: np.ndarray) -> np.ndarray:
        """Decision vector from nodes (N + 1, >= 21), inputs (N, 24) and slacks (N + 1, n_p)."""
        return np.concatenate([x_nodes[:, :_N_X].reshape(-1), u.reshape(-1), slack.reshape(-1)])

    def unpack(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(nodes (N + 1, 21), inputs (N, 24), slacks (N + 1, n_p)) of a decision vector."""
        n_x, n_u, _ = self._sizes
        w = np.asarray(w, dtype=float).reshape(-1)
        return (
            w[:n_x].reshape(self.N + 1, _N_X),
            w[n_x : n_x + n_u].reshape(self.N, cr.INPUT_SIZE),
            w[n_x + n_u :].reshape(self.N + 1, -1),
        )

    def solve(
        self,
        x0_nlp: np.ndarray,
        target_nodes: np.ndarray,
        guess: np.ndarray,
        multipliers: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> dict:
        """One IPOPT solve from x0 (the 21 NLP entries) with the target reference (N + 1, 18).

        Args:
            guess: The starting decision vector (`pack`).
            multipliers: (lam_x, lam_g) of a previous solve (`shift_multipliers`): IPOPT then
                starts from guess and these (IPOPT_WARM_START).

        Returns a dict: w (the answer), lam_x, lam_g, cost, status (IPOPT's return status
        name), iterations, solve_time_s. An exception inside CasADi comes back as the status
        "exception: ..." with w = guess.
        """
        lbx, ubx = self._lbx.copy(), self._ubx.copy()
        lbx[:_N_X] = ubx[:_N_X] = x0_nlp
        args = {
            "x0": guess,
            "lbx": lbx,
            "ubx": ubx,
            "lbg": self._lbg,
            "ubg": self._ubg,
            "p": np.asarray(target_nodes, dtype=float).reshape(-1),
        }
        if multipliers is not None:
            args["lam_x0"], args["lam_g0"] = multipliers
        solver = self._solvers[multipliers is not None]
        start = time.perf_counter()
        try:
            out = solver(**args)
        except RuntimeError as error:
            return {
                "w": np.asarray(guess, dtype=float),
                "lam_x": None,
                "lam_g": None,
                "cost": float("nan"),
                "status": f"exception: {str(error).splitlines()[0]}",
                "iterations": None,
                "solve_time_s": time.perf_counter() - start,
            }
        elapsed = time.perf_counter() - start
        stats = solver.stats()
        return {
            "w": np.asarray(out["x"]).reshape(-1),
            "lam_x": np.asarray(out["lam_x"]).reshape(-1),
            "lam_g": np.asarray(out["lam_g"]).reshape(-1),
            "cost": float(out["f"]),
            "status": str(stats.get("return_status", "unknown")),
            "iterations": int(stats["iter_count"]) if "iter_count" in stats else None,
            "solve_time_s": elapsed,
        }
