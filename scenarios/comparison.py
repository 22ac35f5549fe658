"""Methods compared on the same starts: the shoot-out's tables and figures (issue 22).

Owns: finding the methods of a campaign whose cases fly the same sampled starts (common random
numbers), their two columns (truth-fed, and on the navigation's estimate), and what `rpod
report` says of them: success with its Wilson interval (overall and up to TUMBLE_SPLIT_DEG_S),
delta-v, time to capture, least clearance, exits from the task's docking cone, solver failures
and fallbacks,
compute per control step and real-time factor; every failed run's class; the starts on which
methods disagree, each with a rerunnable case; the figures (success against tumble rate and
against start range, delta-v against range).
Does not own: the runs (sweep.py), the verdicts (rpod.diagrams.mission), the report's files
(report.py).

Which cases are which. A campaign is compared when it samples its starts and has at least two
cases flying the same sample indices. A case's column is `estimated` when its `navigation`
override chooses a filter (any tag but Truth), else `truth-fed`; two cases are one method when
their overrides, the navigation left out, are the same on the same start (`soft_capture` and
`soft_capture_ekf`). The method is named after its truth-fed case.

A failed run's class is the first of these that holds (CLASSES):
- `sim failed`: the simulation did not finish (crash, wall-clock timeout);
- `contact`: the true shapes touched before any capture (a safety event);
- `plan infeasible`: the method's first plan failed (summary `initial_plan_success` false);
- `solver failure`: a solver gave no usable result where one was due (`solver_failures`;
  the designed fallbacks, such as paper 004's best-effort QP outside its corridor, are
  reported apart, as `fallback_s`, and are not a class);
- `navigation`: on the estimate, where the same method captured the same start truth-fed;
- `tracking`: the vehicle did not follow what the method asked: the capture points came
  within eps_p but never slow enough, or the chaser ended farther from the target than it
  started (it was driven away);
- `timeout`: none of the above: the run's time ran out on the way in.
Compute per control step: p50 is the median over runs of each run's median, p99 the median
over runs of each run's 99th percentile (summary `control_step_ms_*`, rpod.systems.step_timer).
"""

import dataclasses
import itertools
import json
import math
import pathlib

import numpy as np

from rpod.models.statistics import SuccessShare
from rpod.scenarios.store import contact_occurred, mission_success, rerun_command

TRUTH_FED, ESTIMATED = "truth-fed", "estimated"
COLUMNS = (TRUTH_FED, ESTIMATED)
TUMBLE_SPLIT_DEG_S = 5.0  # issue 22's goal: >= 95 % up to 5 deg/s truth-fed
CLASSES = (
    "sim failed",
    "contact",
    "plan infeasible",
    "solver failure",
    "navigation",
    "tracking",
    "timeout",
)
MAX_DISAGREEMENTS_LISTED = 25
TUMBLE_KEY, RANGE_KEY = "target.w_IT_T_deg_s", "chaser.p_LC_L"


@dataclasses.dataclass
class Method:
    """One method of the comparison: its name and its case of each column it flies."""

    name: str
    cases: dict  # column -> case name


def _column(overrides: dict) -> str:
    navigation = overrides.get("navigation")
    tag = navigation.get("!tag") if isinstance(navigation, dict) else None
    return ESTIMATED if tag not in (None, "Truth") else TRUTH_FED


def _by_case(rows: list[dict]) -> dict[str, dict[int, dict]]:
    cases = {}
    for row in rows:
        cases.setdefault(row["case_name"], {})[row["sample_index"]] = row
    return cases


def find_methods(rows: list[dict]) -> list[Method]:
    """The methods of a compared campaign (module docstring), in plan order; [] when the
    campaign is not one (no sample, fewer than two cases, or cases on different starts)."""
    if not rows or any(r.get("sample_index") is None or not r.get("case_name") for r in rows):
        return []
    cases = _by_case(rows)
    indices = [set(runs) for runs in cases.values()]
    if len(cases) < 2 or any(s != indices[0] for s in indices[1:]):
        return []
    first = min(indices[0])
    methods = {}
    for case, runs in cases.items():
        overrides = runs[first]["overrides"]
        key = json.dumps({k: v for k, v in overrides.items() if k != "navigation"}, sort_keys=True)
        method = methods.setdefault(key, Method(case, {}))
        column = _column(overrides)
        if column in method.cases:  # two cases in one cell: not a method comparison
            return []
        method.cases[column] = case
        if column == TRUTH_FED:
            method.name = case
    return list(methods.values())


def compared_methods(rows: list[dict]) -> list[Method]:
    """find_methods' methods when there is something to compare (two methods, or one in both
    columns), else []."""
    methods = find_methods(rows)
    if len(methods) < 2 and not any(len(m.cases) == 2 for m in methods):
        return []
    return methods


def _norm(overrides: dict, key: str) -> float:
    value = overrides.get(key)
    return float(np.linalg.norm(value)) if isinstance(value, list) and value else math.nan


def tumble_deg_s(row: dict) -> float:
    """The run's tumble rate |w_IT_T| [deg/s] from its overrides (nan if not overridden)."""
    return _norm(row["overrides"], TUMBLE_KEY)


def start_range_m(row: dict) -> float:
    """The run's start range |p_LC_L| [m] from its overrides (nan if not overridden)."""
    return _norm(row["overrides"], RANGE_KEY)


def _metric(row: dict, key: str):
    return (row["metrics"] or {}).get(key) if row["status"] == "ok" else None


def failure_class(row: dict, truth_fed_twin: dict | None) -> str | None:
    """The class of a run's failure (module docstring), None for a success or no verdict."""
    if mission_success(row) is not False:
        return None
    if row["status"] == "failed":
        return "sim failed"
    capture = (row["metrics"].get("mission") or {}).get("capture") or {}
    if contact_occurred(row) or str(capture.get("reason", "")).startswith("contact"):
        return "contact"
    if _metric(row, "initial_plan_success") is False:
        return "plan infeasible"
    if (_metric(row, "solver_failures") or 0) > 0:
        return "solver failure"
    if truth_fed_twin is not None and mission_success(truth_fed_twin) is True:
        return "navigation"
    final_range = _metric(row, "final_range_m")
    if str(capture.get("reason", "")).startswith("speed") or (
        final_range is not None and final_range > start_range_m(row)
    ):
        return "tracking"
    return "timeout"


@dataclasses.dataclass
class Cell:
    """One method in one column: its runs by sample index."""

    method: str
    column: str
    runs: dict  # sample index -> row


def cells(rows: list[dict], methods: list[Method]) -> list[Cell]:
    """Every (method, column) flown, methods in plan order, truth-fed first."""
    cases = _by_case(rows)
    return [
        Cell(m.name, column, cases[m.cases[column]])
        for m in methods
        for column in COLUMNS
        if column in m.cases
    ]


def _twin(cell: Cell, all_cells: list[Cell], index: int) -> dict | None:
    if cell.column != ESTIMATED:
        return None
    for other in all_cells:
        if other.method == cell.method and other.column == TRUTH_FED:
            return other.runs.get(index)
    return None


def _share(runs) -> SuccessShare:
    verdicts = [v for v in map(mission_success, runs) if v is not None]
    return SuccessShare(sum(verdicts), len(verdicts))


def _fmt(value, digits: int = 3) -> str:
    return "--" if value is None or not math.isfinite(value) else f"{value:.{digits}g}"


def _values(runs, key: str, only_success: bool = False) -> np.ndarray:
    values = [
        _metric(r, key)
        for r in runs
        if r["status"] == "ok" and (not only_success or mission_success(r) is True)
    ]
    return np.array([float(v) for v in values if isinstance(v, (int, float)) and v is not None])


def _percentile(values: np.ndarray, q: float) -> float | None:
    return float(np.percentile(values, q)) if values.size else None


def _capture_times(runs) -> np.ndarray:
    times = [
        ((r["metrics"].get("mission") or {}).get("capture") or {}).get("time_s")
        for r in runs
        if mission_success(r) is True
    ]
    return np.array([float(t) for t in times if t is not None])


def cell_statistics(cell: Cell) -> dict:
    """The comparison's figures of one cell (module docstring), numbers or None."""
    runs = list(cell.runs.values())
    slow = [r for r in runs if tumble_deg_s(r) <= TUMBLE_SPLIT_DEG_S]
    dv = _values(runs, "delta_v_m_s", only_success=True)
    clearance = _values(runs, "min_separation_m")
    corridor = _values(runs, "max_corridor_violation_deg")
    failures = _values(runs, "solver_failures")
    fallback = _values(runs, "fallback_s")
    return {
        "success": _share(runs),
        "success_slow": _share(slow),
        "delta_v_p50": _percentile(dv, 50),
        "delta_v_p90": _percentile(dv, 90),
        "capture_time_p50": _percentile(_capture_times(runs), 50),
        "least_clearance": float(clearance.min()) if clearance.size else None,
        "corridor_runs": int(np.count_nonzero(corridor > 0)) if corridor.size else None,
        "solver_failure_runs": int(np.count_nonzero(failures > 0)) if failures.size else None,
        "fallback_runs": int(np.count_nonzero(fallback > 0)) if fallback.size else None,
        "step_ms_p50": _percentile(_values(runs, "control_step_ms_p50"), 50),
        "step_ms_p99": _percentile(_values(runs, "control_step_ms_p99"), 50),
        "rtf_p50": _percentile(_values(runs, "real_time_factor"), 50),
    }


def failure_counts(cell: Cell, all_cells: list[Cell]) -> dict[str, int]:
    """Failed runs of the cell by class (CLASSES order; classes with none left out)."""
    counts = dict.fromkeys(CLASSES, 0)
    for index, row in cell.runs.items():
        kind = failure_class(row, _twin(cell, all_cells, index))
        if kind is not None:
            counts[kind] += 1
    return {k: n for k, n in counts.items() if n}


def disagreements(all_cells: list[Cell]) -> list[dict]:
    """Every (start, column) on which some methods captured and others did not: the start's
    sample index, tumble and range, who captured, and who failed with their run ids."""
    found = []
    for column in COLUMNS:
        flown = [c for c in all_cells if c.column == column]
        if len(flown) < 2:
            continue
        for index in sorted(flown[0].runs):
            verdicts = {c.method: mission_success(c.runs[index]) for c in flown}
            if True in verdicts.values() and False in verdicts.values():
                row = flown[0].runs[index]
                found.append(
                    {
                        "sample_index": index,
                        "column": column,
                        "tumble_deg_s": tumble_deg_s(row),
                        "start_range_m": start_range_m(row),
                        "captured": [m for m, v in verdicts.items() if v is True],
                        "failed": {
                            c.method: c.runs[index]["run_id"]
                            for c in flown
                            if verdicts[c.method] is False
                        },
                    }
                )
    return found


def _cell_label(cell: Cell) -> str:
    return f"{cell.method} ({cell.column})"


def comparison_lines(meta: dict, rows: list[dict], results_folder: str, table) -> list[str]:
    """The report's comparison section as text lines ([] when the campaign compares no
    methods); `table(header, rows, right)` lays out a table (report.py's)."""
    methods = compared_methods(rows)
    if not methods:
        return []
    all_cells = cells(rows, methods)
    stats = {id(c): cell_statistics(c) for c in all_cells}
    lines = [
        "",
        (
            f"Methods compared on the same {len(all_cells[0].runs)} starts "
            "(success: the mission's criterion; delta-v and time over the captured runs):"
        ),
        "",
    ]
    success_rows = []
    for method in methods:
        row = [method.name]
        for column in COLUMNS:
            cell = next(
                (c for c in all_cells if c.method == method.name and c.column == column), None
            )
            s = stats[id(cell)] if cell else None
            row += (
                [s["success"].percent_text(), s["success_slow"].percent_text()]
                if s
                else ["--", "--"]
            )
        success_rows.append(row)
    split = f"<= {TUMBLE_SPLIT_DEG_S:g} deg/s"
    lines += table(
        ["method", "truth-fed", f"truth-fed {split}", "estimated", f"estimated {split}"],
        success_rows,
        set(),
    )
    lines += ["", "Cost, safety and compute:", ""]
    cost_rows = []
    for cell in all_cells:
        s = stats[id(cell)]
        cost_rows.append(
            [
                cell.method,
                cell.column,
                _fmt(s["delta_v_p50"]),
                _fmt(s["delta_v_p90"]),
                _fmt(s["capture_time_p50"]),
                _fmt(s["least_clearance"]),
                "--" if s["corridor_runs"] is None else s["corridor_runs"],
                "--" if s["solver_failure_runs"] is None else s["solver_failure_runs"],
                "--" if s["fallback_runs"] is None else s["fallback_runs"],
                _fmt(s["step_ms_p50"]),
                _fmt(s["step_ms_p99"]),
                _fmt(s["rtf_p50"]),
            ]
        )
    lines += table(
        [
            "method",
            "column",
            "dv p50 m/s",
            "dv p90 m/s",
            "capture s",
            "least clearance m",
            "cone left",
            "solver failed",
            "fallback",
            "step p50 ms",
            "step p99 ms",
            "RTF",
        ],
        cost_rows,
        set(range(2, 12)),
    )
    lines += [
        "",
        (
            "(cone left, solver failed, fallback: runs; -- where the method has no such figure. "
            "cone left: runs outside the task's docking cone (target.corridor_half_angle_deg "
            "about the port's axis, within target.corridor_length_m; summary "
            "max_corridor_violation_deg > 0), the same cone for every method. step: compute per "
            "control step, medians over runs of each run's p50 and p99)"
        ),
        "",
        "Failed runs by class (rpod.scenarios.comparison):",
        "",
    ]
    failure_rows = []
    for cell in all_cells:
        counts = failure_counts(cell, all_cells)
        failure_rows.append([cell.method, cell.column] + [counts.get(k, 0) for k in CLASSES])
    lines += table(["method", "column", *CLASSES], failure_rows, set(range(2, 2 + len(CLASSES))))
    found = disagreements(all_cells)
    lines += ["", f"Starts on which methods disagree: {len(found)}", ""]
    listed = []
    for d in found[:MAX_DISAGREEMENTS_LISTED]:
        method, run_id = next(iter(d["failed"].items()))
        listed.append(
            [
                d["sample_index"],
                d["column"],
                _fmt(d["tumble_deg_s"]),
                _fmt(d["start_range_m"]),
                ", ".join(d["captured"]),
                ", ".join(d["failed"]),
                rerun_command(meta, results_folder, run_id),
            ]
        )
    if listed:
        lines += table(
            ["start", "column", "deg/s", "range m", "captured", "failed", "rerun (first failed)"],
            listed,
            {0, 2, 3},
        )
        if len(found) > len(listed):
            lines.append(f"({len(found) - len(listed)} more not listed)")
    return lines


def _binned_success(runs: list[dict], values: np.ndarray, edges: np.ndarray):
    centres, shares = [], []
    for low, high in itertools.pairwise(edges):
        chosen = [r for r, v in zip(runs, values) if low <= v < high or (v == high == edges[-1])]
        share = _share(chosen)
        if share.n:
            centres.append(0.5 * (low + high))
            shares.append(100.0 * share.share)
    return centres, shares


def _pending(cell: Cell) -> int:
    return sum(1 for r in cell.runs.values() if r["status"] == "pending")


def success_curve_label(cell: Cell) -> str:
    """A success curve's legend entry: a cell with runs still pending is not drawn (a few
    flown runs would read as the method's curve), and its entry says so."""
    pending = _pending(cell)
    if pending:
        return f"{_cell_label(cell)}: not drawn, {pending} of {len(cell.runs)} runs pending"
    return _cell_label(cell)


def comparison_figures(rows: list[dict], out_dir: pathlib.Path) -> list[pathlib.Path]:
    """success_vs_tumble.png, success_vs_range.png and delta_v_vs_range.png: one curve per
    method and column (truth-fed solid, estimated dashed; a column with runs still pending is
    named in the legend, not drawn); [] when no methods are compared."""
    from matplotlib.figure import Figure

    methods = compared_methods(rows)
    if not methods:
        return []
    all_cells = cells(rows, methods)
    colours = {m.name: f"C{i}" for i, m in enumerate(methods)}
    style = {TRUTH_FED: "-", ESTIMATED: "--"}
    paths = []
    for name, axis, label in (
        ("success_vs_tumble.png", tumble_deg_s, "tumble rate |w_IT| [deg/s]"),
        ("success_vs_range.png", start_range_m, "start range [m]"),
    ):
        figure = Figure(figsize=(7, 4.2))
        axes = figure.add_subplot()
        everything = np.array([axis(r) for c in all_cells for r in c.runs.values()])
        everything = everything[np.isfinite(everything)]
        if everything.size == 0:
            continue
        edges = np.linspace(everything.min(), everything.max(), 7)
        for cell in all_cells:
            runs = list(cell.runs.values())
            x, y = _binned_success(runs, np.array([axis(r) for r in runs]), edges)
            if _pending(cell):
                x, y = [], []
            axes.plot(
                x,
                y,
                style[cell.column],
                marker="o",
                color=colours[cell.method],
                label=success_curve_label(cell),
            )
        axes.set_xlabel(label)
        axes.set_ylabel("captured [%]")
        axes.set_ylim(-3, 103)
        axes.grid(alpha=0.3)
        axes.legend(fontsize=7)
        axes.set_title(f"Success against {label.split(' [')[0]} ({len(edges) - 1} bins)")
        figure.tight_layout()
        figure.savefig(out_dir / name, dpi=110)
        paths.append(out_dir / name)
    figure = Figure(figsize=(7, 4.2))
    axes = figure.add_subplot()
    for cell in all_cells:
        runs = [r for r in cell.runs.values() if mission_success(r) is True]
        x = [start_range_m(r) for r in runs]
        y = [_metric(r, "delta_v_m_s") for r in runs]
        axes.scatter(
            x,
            y,
            s=10,
            color=colours[cell.method],
            marker="o" if cell.column == TRUTH_FED else "x",
            label=f"{_cell_label(cell)}: {len(runs)} captured"
            + (f" ({_pending(cell)} runs pending)" if _pending(cell) else ""),
        )
    axes.set_xlabel("start range [m]")
    axes.set_ylabel("delta-v [m/s]")
    axes.set_title("Delta-v of the captured runs against start range")
    axes.grid(alpha=0.3)
    axes.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(out_dir / "delta_v_vs_range.png", dpi=110)
    paths.append(out_dir / "delta_v_vs_range.png")
    return paths
