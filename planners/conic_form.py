"""A MathematicalProgram's cone program in standard form, solved by QOCO, ECOS or Clarabel from
their own Python packages.

Owns: writing a program of linear costs and linear-equality, linear, bounding-box and
Lorentz-cone constraints as

    min c^T z   s.t.   A z + s = b,   s in K = {0}^p x R_+^l x Q^q1 x ... x Q^qk     (SF)

(Clarabel's convention: the zero cone first, then the orthant, then the second-order cones, in
the program's order), rewriting the rows of chosen bindings when their coefficients change
(`refresh`), and one solve of (SF) by a named solver (`solve_conic`). Does not own: building the
programs (the planners) or Drake's own solver interfaces.

Why: Drake wraps Clarabel but neither QOCO nor ECOS, and issue 23 compares the three on the
same program. The program stays the one definition; this module reads its bindings.

Rows of each binding (Drake's conventions on the left):
- linear equality ``A z = b``: rows of the zero cone, ``A z + s = b``;
- linear ``lb <= A z <= ub`` and bounding box ``lb <= z <= ub``: a row of the zero cone where
  lb = ub, else one orthant row ``A z + s = ub`` per finite ub and ``-A z + s = -lb`` per finite
  lb (which rows exist is fixed when the form is built: `refresh` refuses a binding whose finite
  bounds changed);
- Lorentz cone ``A z + b in Q`` (first entry >= norm of the rest): ``-A z + s = b``.
(SF) keeps each binding's nonzero entries as they are when the form is built: a binding named
in ``dynamic`` (rewritten between solves) must hold every nonzero it will ever have by then,
and `refresh` raises if a new coefficient falls outside that pattern.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import scipy.sparse as sp

# The solvers solve_conic knows, by the name a planner's settings use.
CONIC_SOLVERS = ("qoco", "ecos", "clarabel")


@dataclasses.dataclass
class _Block:
    """The rows one binding owns in (SF) and its entries of A.

    Row r of the binding's own matrix makes the (SF) rows ``rows[source == r]`` (none, one or,
    for a two-sided bound, two); entry e of A is ``sign[e] * M[i[e], j[e]]`` of the binding's
    matrix M.
    """

    evaluator: object
    kind: str  # "equality", "linear", "box", "lorentz"
    rows: np.ndarray  # (SF) rows
    source: np.ndarray  # the binding's row behind each (SF) row
    upper: np.ndarray  # per (SF) row: True for M z <= ub (and equalities, cones), False for lb
    entries: slice  # this block's entries in ConicForm's entry arrays
    i: np.ndarray  # per entry: row of M
    j: np.ndarray  # per entry: column of M
    sign: np.ndarray  # per entry: +1 or -1
    finite: tuple[np.ndarray, np.ndarray] | None  # (lb, ub) rows that make orthant rows
    mask: np.ndarray | None  # a dynamic binding's pattern, to check `refresh` stays inside it


class ConicForm:
    """(SF) for a program: `c` and `c_offset`, `A` (CSC, m x n), `b`, and the cone sizes
    `zero`, `orthant` and `soc` (a list).

    Args:
        prog: The MathematicalProgram: linear costs, linear-equality, linear, bounding-box and
            Lorentz-cone constraints only (anything else is a ValueError).
        dynamic: Evaluators whose coefficients the caller rewrites between solves (`refresh`
            rereads them, within their nonzero pattern at build: module docstring).
    """

    def __init__(self, prog, dynamic=()):
        linear_types, lorentz_types = _constraint_types()
        unsupported = [
            type(b.evaluator()).__name__
            for b in prog.GetAllConstraints()
            if not isinstance(b.evaluator(), linear_types + lorentz_types)
        ]
        if len(prog.GetAllCosts()) != len(prog.linear_costs()):
            unsupported.append("a cost that is not linear")
        if unsupported:
            raise ValueError(f"ConicForm: unsupported costs or constraints: {unsupported[:3]}")
        self.n = prog.num_vars()
        self._prog = prog
        self._dynamic = tuple(dynamic)
        bindings = (
            [("equality", b) for b in prog.linear_equality_constraints()]
            + [("linear", b) for b in prog.linear_constraints()]
            + [("box", b) for b in prog.bounding_box_constraints()]
        )
        cones = [("lorentz", b) for b in prog.lorentz_cone_constraints()]
        # Row counts per cone first: the zero cone's rows, then the orthant's, then the cones'.
        self.zero = self.orthant = 0
        for kind, binding in bindings:
            lower, upper = _bounds(kind, binding.evaluator())
            equal = lower == upper
            self.zero += int(np.count_nonzero(equal))
            self.orthant += int(np.count_nonzero(~equal & np.isfinite(upper)))
            self.orthant += int(np.count_nonzero(~equal & np.isfinite(lower)))
        next_row = {"zero": 0, "orthant": self.zero, "cone": self.zero + self.orthant}
        self.soc: list[int] = []
        self._blocks: list[_Block] = []
        entry_rows, entry_cols, count = [], [], 0
        for kind, binding in bindings + cones:
            evaluator = binding.evaluator()
            columns = np.asarray(prog.FindDecisionVariableIndices(binding.variables()), int)
            if kind == "lorentz":
                size = evaluator.A().shape[0]
                source, upper_side, finite = np.arange(size), np.ones(size, bool), None
                rows = next_row["cone"] + source
                next_row["cone"] += size
                self.soc.append(size)
            else:
                lower, upper = _bounds(kind, evaluator)
                equal = lower == upper
                finite = (np.isfinite(lower) & ~equal, np.isfinite(upper) & ~equal)
                eq_src = np.flatnonzero(equal)
                ub_src, lb_src = np.flatnonzero(finite[1]), np.flatnonzero(finite[0])
                source = np.concatenate([eq_src, ub_src, lb_src])
                upper_side = np.arange(len(source)) < len(eq_src) + len(ub_src)
                orthant = len(ub_src) + len(lb_src)
                rows = np.concatenate(
                    [
                        next_row["zero"] + np.arange(len(eq_src)),
                        next_row["orthant"] + np.arange(orthant),
                    ]
                )
                next_row["zero"] += len(eq_src)
                next_row["orthant"] += orthant
            pattern_i, pattern_j = _pattern(kind, evaluator)
            # Every pattern entry, once for each (SF) row its binding row makes.
            order = np.argsort(pattern_i, kind="stable")
            pattern_i, pattern_j = pattern_i[order], pattern_j[order]
            first = np.searchsorted(pattern_i, source)
            last = np.searchsorted(pattern_i, source, side="right")
            picked = [np.arange(a, b) for a, b in zip(first, last)]
            taken = np.concatenate(picked).astype(int) if picked else np.zeros(0, int)
            position = np.repeat(np.arange(len(source)), last - first)
            i, j = pattern_i[taken], pattern_j[taken]
            mask = None
            if any(evaluator is d for d in self._dynamic):
                mask = np.zeros(_shape(kind, evaluator), dtype=bool)
                mask[pattern_i, pattern_j] = True
            # Drake's cone is M z + d in Q: (SF) is -M z + s = d. Bounds: +M z <= ub, -M z <= -lb.
            sign = np.where(upper_side[position], 1.0, -1.0) * (-1.0 if kind == "lorentz" else 1.0)
            self._blocks.append(
                _Block(
                    evaluator=evaluator,
                    kind=kind,
                    rows=rows.astype(int),
                    source=source.astype(int),
                    upper=upper_side,
                    entries=slice(count, count + len(i)),
                    i=i,
                    j=j,
                    sign=sign,
                    finite=finite,
                    mask=mask,
                )
            )
            entry_rows.append(rows[position])
            entry_cols.append(columns[j])
            count += len(i)
        found = sum(any(block.evaluator is d for block in self._blocks) for d in self._dynamic)
        if found != len(self._dynamic):
            raise ValueError("ConicForm: a dynamic evaluator is not one of the program's")
        self.m = next_row["cone"]
        rows_all = np.concatenate(entry_rows).astype(int)
        cols_all = np.concatenate(entry_cols).astype(int)
        # CSC slots: entries sorted by (column, row); duplicates (a variable listed twice in a
        # binding) share a slot and are summed.
        unique, self._slot = np.unique(cols_all * self.m + rows_all, return_inverse=True)
        indptr = np.searchsorted(unique // self.m, np.arange(self.n + 1))
        self.A = sp.csc_matrix(
            (np.zeros(len(unique)), unique % self.m, indptr), shape=(self.m, self.n)
        )
        self._values = np.zeros(count)
        self.b = np.zeros(self.m)
        self.c = np.zeros(self.n)
        self.c_offset = 0.0
        self.refresh(every_binding=True)

    def refresh(self, every_binding: bool = False) -> None:
        """Rereads the dynamic bindings (every binding if every_binding) and the costs."""
        for block in self._blocks:
            if every_binding or any(block.evaluator is d for d in self._dynamic):
                self._read(block)
        self.A.data[:] = np.bincount(self._slot, weights=self._values, minlength=self.A.nnz)
        self.c[:] = 0.0
        self.c_offset = 0.0
        for binding in self._prog.linear_costs():
            columns = self._prog.FindDecisionVariableIndices(binding.variables())
            np.add.at(self.c, columns, binding.evaluator().a())
            self.c_offset += binding.evaluator().b()

    def _read(self, block: _Block) -> None:
        evaluator = block.evaluator
        if block.kind == "lorentz":
            matrix = evaluator.A().toarray()
            self.b[block.rows] = evaluator.b()[block.source]
        else:
            matrix = _dense_A(block.kind, evaluator)
            lower, upper = _bounds(block.kind, evaluator)
            equal = lower == upper
            if not (
                np.array_equal(np.isfinite(lower) & ~equal, block.finite[0])
                and np.array_equal(np.isfinite(upper) & ~equal, block.finite[1])
            ):
                raise ValueError("ConicForm.refresh: a binding's finite bounds changed")
            self.b[block.rows] = np.where(block.upper, upper[block.source], -lower[block.source])
        if block.mask is not None and np.any((matrix != 0.0) & ~block.mask):
            raise ValueError(
                "ConicForm.refresh: a coefficient outside the binding's pattern at build; "
                "give it every nonzero it will have before building the form"
            )
        self._values[block.entries] = block.sign * matrix[block.i, block.j]

    def cones_clarabel(self):
        """The cones as the `clarabel` package takes them."""
        import clarabel

        cones = []
        if self.zero:
            cones.append(clarabel.ZeroConeT(self.zero))
        if self.orthant:
            cones.append(clarabel.NonnegativeConeT(self.orthant))
        return cones + [clarabel.SecondOrderConeT(size) for size in self.soc]


def _dense_A(kind: str, evaluator) -> np.ndarray:
    if kind == "box":
        return np.eye(len(evaluator.lower_bound()))
    return evaluator.GetDenseA()


def _bounds(kind: str, evaluator) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(evaluator.lower_bound(), float), np.asarray(evaluator.upper_bound(), float)


def _shape(kind: str, evaluator) -> tuple[int, int]:
    if kind == "box":
        return (len(evaluator.lower_bound()),) * 2
    return evaluator.A().shape if kind == "lorentz" else evaluator.get_sparse_A().shape


def _pattern(kind: str, evaluator) -> tuple[np.ndarray, np.ndarray]:
    """(rows, columns) of the binding's nonzero matrix entries: those (SF) keeps."""
    if kind == "box":
        size = len(evaluator.lower_bound())
        return np.arange(size), np.arange(size)
    matrix = sp.coo_matrix(evaluator.A() if kind == "lorentz" else evaluator.get_sparse_A())
    keep = matrix.data != 0.0
    return matrix.row[keep].astype(int), matrix.col[keep].astype(int)


def _constraint_types():
    from pydrake.solvers import (
        BoundingBoxConstraint,
        LinearConstraint,
        LinearEqualityConstraint,
        LorentzConeConstraint,
    )

    return (LinearConstraint, LinearEqualityConstraint, BoundingBoxConstraint), (
        LorentzConeConstraint,
    )


@dataclasses.dataclass(frozen=True)
class ConicSolution:
    """One solve of (SF).

    Attributes:
        status: "solved", "infeasible", "iteration_limit" or "failed".
        solver_status: The solver's own status word.
        z: The solution (n,), NaN unless solved.
        cost: c^T z plus the costs' constants (NaN unless solved).
        iterations: Interior-point iterations.
        solve_time_s: Wall time of the setup and the solve [s].
    """

    status: str
    solver_status: str
    z: np.ndarray
    cost: float
    iterations: int
    solve_time_s: float


def solve_conic(form: ConicForm, solver: str, settings: dict | None = None) -> ConicSolution:
    """Solves (SF) with `solver` (one of CONIC_SOLVERS) from its own package; never raises on
    an infeasible or failed solve (its status says so).

    QOCO has no infeasibility detection: an infeasible program ends at its iteration limit,
    "iteration_limit", not "infeasible".
    """
    settings = dict(settings or {})
    start = time.perf_counter()
    if solver == "qoco":
        status, word, z, iterations = _qoco(form, settings)
    elif solver == "ecos":
        status, word, z, iterations = _ecos(form, settings)
    elif solver == "clarabel":
        status, word, z, iterations = _clarabel(form, settings)
    else:
        raise ValueError(f"solver must be one of {CONIC_SOLVERS}, got {solver!r}")
    elapsed = time.perf_counter() - start
    if status != "solved":
        z = np.full(form.n, np.nan)
    return ConicSolution(
        status=status,
        solver_status=word,
        z=z,
        cost=float(form.c @ z + form.c_offset),
        iterations=int(iterations),
        solve_time_s=elapsed,
    )


def _split(form: ConicForm):
    """(A_eq, b_eq, G, h): the zero-cone rows apart from the rest (QOCO's and ECOS's form)."""
    A = form.A.tocsr()
    p = form.zero
    return A[:p].tocsc(), form.b[:p], A[p:].tocsc(), form.b[p:]


def _qoco(form: ConicForm, settings: dict):
    import qoco

    A_eq, b_eq, G, h = _split(form)
    solver = qoco.QOCO()
    solver.setup(
        form.n,
        G.shape[0],
        A_eq.shape[0],
        None,
        form.c,
        A_eq if A_eq.shape[0] else None,
        b_eq if A_eq.shape[0] else None,
        G,
        h,
        form.orthant,
        len(form.soc),
        np.asarray(form.soc, dtype=int),
        **{"verbose": False, **settings},
    )
    result = solver.solve()
    word = str(result.status)
    status = {
        "QOCO_SOLVED": "solved",
        "QOCO_MAX_ITER": "iteration_limit",
    }.get(word, "failed")
    return status, word, np.asarray(result.x, dtype=float), result.iters


def _ecos(form: ConicForm, settings: dict):
    import ecos

    A_eq, b_eq, G, h = _split(form)
    dims = {"l": form.orthant, "q": list(form.soc)}
    extra = {"A": A_eq, "b": b_eq} if A_eq.shape[0] else {}
    result = ecos.solve(form.c, G, h, dims, **extra, **{"verbose": False, **settings})
    flag = int(result["info"]["exitFlag"])
    # ECOS exit flags: 0 optimal, 1 primal infeasible, 2 dual infeasible, -1 max iterations.
    status = {0: "solved", 1: "infeasible", 2: "infeasible", -1: "iteration_limit"}.get(
        flag, "failed"
    )
    word = str(result["info"]["infostring"])
    return status, word, np.asarray(result["x"], dtype=float), result["info"]["iter"]


def _clarabel(form: ConicForm, settings: dict):
    import clarabel

    options = clarabel.DefaultSettings()
    options.verbose = False
    for key, value in settings.items():
        setattr(options, key, value)
    P = sp.csc_matrix((form.n, form.n))
    solution = clarabel.DefaultSolver(
        P, form.c, form.A, form.b, form.cones_clarabel(), options
    ).solve()
    word = str(solution.status).split(".")[-1]
    status = {
        "Solved": "solved",
        "PrimalInfeasible": "infeasible",
        "DualInfeasible": "infeasible",
        "MaxIterations": "iteration_limit",
    }.get(word, "failed")
    return status, word, np.asarray(solution.x, dtype=float), solution.iterations
