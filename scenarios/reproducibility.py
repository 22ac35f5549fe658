"""Whether a second flight of a campaign gives the same numbers: which of a run's results are
reproducible, and the run-by-run comparison of two stores' runs.

Owns: a run's reproducible record (everything in its summary but what measures the machine)
and `compare_runs`. Does not own: reading stores (store.py) or reports (report.py).

A record is the run's status and mission verdict (and a failed run's reason), then every scalar
of its summary (one level of nested dicts flattened as `parent.key`, short numeric vectors as
`key[i]`, floats by `repr`, which reads back to the same double). Left out: what measures the
machine rather than the flight (wall, build and solve times, compute per control step, the
real-time factor). Two runs with the same id are compared only when they are two flights (their
`finished_at` differ): a run recorded from another store (`rpod sweep --reuse`) is the same
flight, counted apart.
"""

from __future__ import annotations

import dataclasses

from rpod.scenarios.store import counterparts, mission_success

# Summary keys (or parts of them) that measure the machine, not the flight.
MACHINE_KEYS = (
    "wall_time",
    "build_time",
    "solve_time",
    "solve_ms",
    "check_time",
    "real_time_factor",
    "control_step_ms",
)
# Vectors longer than this (trajectories, code lists) are not compared.
MAX_VECTOR = 6


def _machine_key(key: str) -> bool:
    return any(part in key for part in MACHINE_KEYS)


def _cell(value) -> str | None:
    """The text of one scalar, or None when value is not a scalar."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return " ".join(value.split())
    return None


def _flatten(metrics: dict, prefix: str = "", depth: int = 0) -> dict[str, str]:
    cells = {}
    for key, value in metrics.items():
        name = f"{prefix}{key}"
        if _machine_key(name):
            continue
        text = _cell(value)
        if text is not None:
            cells[name] = text
        elif isinstance(value, dict) and depth == 0:
            cells.update(_flatten(value, f"{name}.", depth + 1))
        elif (
            isinstance(value, list)
            and 0 < len(value) <= MAX_VECTOR
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        ):
            cells.update({f"{name}[{i}]": repr(v) for i, v in enumerate(value)})
    return cells


def run_record(row: dict) -> dict[str, str]:
    """The reproducible cells of one stored run (a `ResultStore.rows()` row)."""
    verdict = mission_success(row)
    record = {
        "status": row["status"],
        "mission_success": "" if verdict is None else ("true" if verdict else "false"),
    }
    if row["status"] == "ok" and row["metrics"]:
        record.update(_flatten(row["metrics"]))
    elif row["status"] == "failed":
        record["reason"] = " ".join(str(row["reason"] or "").split())
    return record


@dataclasses.dataclass
class RunComparison:
    """Runs finished in both stores: how many were flown twice and compared, which of them
    differ and in which cells, and how many are one flight recorded twice."""

    compared: int
    differing: dict[str, list[str]]  # run id -> the cells whose values differ
    only_here: int  # finished here, absent or unfinished there
    only_there: int  # finished there, absent or unfinished here
    same_flight: int  # the same finished_at: a reused or copied result, not a second flight

    @property
    def same(self) -> int:
        return self.compared - len(self.differing)


def compare_runs(rows: list[dict], earlier: list[dict], by_start: bool = False) -> RunComparison:
    """Compares the finished runs of rows with those of earlier (both `ResultStore.rows()`),
    each with its counterpart (rpod.scenarios.store.counterparts: the same run id, or, with
    by_start (the two plans share their base: store.same_base), the same start to a rounding
    residue when the two were planned on different CPUs), every reproducible cell of either
    (one a record lacks counts as a difference)."""
    here = [row for row in rows if row["status"] != "pending"]
    there = [row for row in earlier if row["status"] != "pending"]
    matches = counterparts(here, there, by_start)
    by_id = {row["run_id"]: row for row in here}
    again = {
        run_id: match
        for run_id, match in matches.items()
        if match["finished_at"] != by_id[run_id]["finished_at"]
    }
    differing = {}
    for run_id, match in again.items():
        new, old = run_record(by_id[run_id]), run_record(match)
        cells = sorted(key for key in new.keys() | old.keys() if new.get(key) != old.get(key))
        if cells:
            differing[run_id] = cells
    matched_there = {id(match) for match in matches.values()}
    return RunComparison(
        compared=len(again),
        differing=differing,
        only_here=len(here) - len(matches),
        only_there=sum(1 for row in there if id(row) not in matched_there),
        same_flight=len(matches) - len(again),
    )
