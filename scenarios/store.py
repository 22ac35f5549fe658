"""The results store of a campaign: one SQLite file, `results.sqlite`, in the output folder.

Owns: the schema, writing the plan (every run, `pending`), recording each result as it arrives,
and reading runs back for resuming and reporting.
Does not own: planning (campaign.py), running (sweep.py) or summarising (report.py).

Why SQLite rather than Parquet:
- A result must be durable the moment it arrives, one run at a time, and survive a SIGKILL of
  the driver. An SQLite commit is atomic: after a crash the file holds exactly the committed
  results, never half a row. Parquet files are written whole, so this would need a file per run
  and a later compaction step.
- "No run lost or duplicated" is a primary key (`run_id`). A result is written by
  `UPDATE ... WHERE run_id = ? AND status = 'pending'`, so a run is recorded at most once, even
  if it was executed twice (see below).
- It is in the standard library, it is one file, and it can be queried with any SQLite tool
  while a campaign runs (WAL mode: readers do not block the writer).

Durability: WAL journal with synchronous=NORMAL. A commit survives the death of the process
(SIGKILL, a crash), which is the case this store is built for. On a power cut, the last few
commits may be rolled back. Those runs are simply pending again and are re-run on resume. They
are still never duplicated.

Execution is at-least-once and recording is exactly-once. A run that finished on a worker after
the driver was killed, but before its result was committed, runs again on resume.

Schema (`runs`): run_id (primary key), plan_index, grp (group label), case_name, grid_point
(JSON), sample_index, overrides (JSON), status ('pending' | 'ok' | 'failed'), reason (one line:
why it failed), detail (traceback or stderr tail), metrics (JSON: the run's summary),
wall_time_s (the worker-side time of the run), worker, finished_at (UTC, ISO 8601).
`meta` holds the campaign's name, source text, base scenario YAML, grid and plan fingerprint.
"""

import datetime
import hashlib
import json
import pathlib
import sqlite3

from rpod.scenarios.loader import ScenarioFileError

STORE_NAME = "results.sqlite"
SCHEMA_VERSION = "1"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs (
    run_id TEXT PRIMARY KEY,
    plan_index INTEGER NOT NULL,
    grp TEXT NOT NULL,
    case_name TEXT NOT NULL,
    grid_point TEXT NOT NULL,
    sample_index INTEGER,
    overrides TEXT NOT NULL,
    status TEXT NOT NULL DEFAULT 'pending' CHECK (status IN ('pending', 'ok', 'failed')),
    reason TEXT,
    detail TEXT,
    metrics TEXT,
    wall_time_s REAL,
    worker TEXT,
    finished_at TEXT
);
"""


def plan_fingerprint(run_ids) -> str:
    """A hash of the set of run ids: two plans with the same runs have the same fingerprint."""
    return hashlib.sha256("\n".join(sorted(run_ids)).encode()).hexdigest()


def store_path(results: pathlib.Path) -> pathlib.Path:
    """The store file of a campaign output folder (or the file itself)."""
    results = pathlib.Path(results)
    return results / STORE_NAME if results.is_dir() or not results.suffix else results


class ResultStore:
    """An open results store. Every write is its own transaction, committed before returning."""

    def __init__(self, path: pathlib.Path):
        self.path = pathlib.Path(path)
        self._connection = sqlite3.connect(self.path, timeout=30.0)
        self._connection.execute("PRAGMA journal_mode=WAL")
        self._connection.execute("PRAGMA synchronous=NORMAL")
        with self._connection:
            self._connection.executescript(_SCHEMA)

    @classmethod
    def open_existing(cls, results) -> "ResultStore":
        """The store of an output folder (or file) that must exist; ScenarioFileError if not."""
        path = store_path(results)
        if not path.is_file():
            raise ScenarioFileError(f"{results}: no results store ({STORE_NAME}) there")
        try:
            store = cls(path)
            store.meta()
        except sqlite3.DatabaseError as error:
            raise ScenarioFileError(f"{path}: not a results store: {error}") from None
        return store

    @staticmethod
    def check_compatible(path: pathlib.Path, fingerprint: str, run_count: int) -> None:
        """ScenarioFileError if an existing store at path holds a different plan."""
        if not path.is_file():
            return
        try:
            connection = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=30.0)
            try:
                row = connection.execute(
                    "SELECT value FROM meta WHERE key = 'plan_fingerprint'"
                ).fetchone()
                stored_count = connection.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
            finally:
                connection.close()
        except sqlite3.DatabaseError as error:
            raise ScenarioFileError(f"{path}: not a results store: {error}") from None
        if row is not None and row[0] != fingerprint:
            raise ScenarioFileError(
                f"{path}: --out: holds the results of a different plan ({stored_count} runs "
                f"stored, {run_count} planned; the base, the variations or the seed differ); "
                "choose another --out"
            )

    def close(self) -> None:
        self._connection.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def write_plan(self, meta: dict, runs) -> None:
        """Stores the campaign's metadata and inserts every planned run not already there."""
        rows = [
            (
                r.run_id,
                r.index,
                r.group,
                r.case,
                json.dumps(r.grid_point),
                r.sample_index,
                json.dumps(r.overrides),
            )
            for r in runs
        ]
        meta = {
            **meta,
            "schema_version": SCHEMA_VERSION,
            "plan_fingerprint": plan_fingerprint(r.run_id for r in runs),
        }
        with self._connection:
            self._connection.executemany(
                "INSERT OR IGNORE INTO meta (key, value) VALUES (?, ?)",
                [
                    (key, value if isinstance(value, str) else json.dumps(value))
                    for key, value in meta.items()
                ],
            )
            self._connection.executemany(
                "INSERT OR IGNORE INTO runs (run_id, plan_index, grp, case_name, grid_point, "
                "sample_index, overrides) VALUES (?, ?, ?, ?, ?, ?, ?)",
                rows,
            )

    def record(self, run_id: str, result: dict) -> bool:
        """Records a finished run once; False if it was already recorded (or is unknown)."""
        status = "ok" if result["status"] == "ok" else "failed"
        finished = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="milliseconds")
        with self._connection:
            cursor = self._connection.execute(
                "UPDATE runs SET status = ?, reason = ?, detail = ?, metrics = ?, wall_time_s = ?,"
                " worker = ?, finished_at = ? WHERE run_id = ? AND status = 'pending'",
                (
                    status,
                    result.get("reason"),
                    result.get("detail"),
                    json.dumps(result["metrics"]) if result.get("metrics") is not None else None,
                    result.get("wall_time_s"),
                    result.get("worker"),
                    finished,
                    run_id,
                ),
            )
        return cursor.rowcount == 1

    def pending_ids(self) -> list[str]:
        """Ids of the runs not yet recorded, in plan order."""
        rows = self._connection.execute(
            "SELECT run_id FROM runs WHERE status = 'pending' ORDER BY plan_index"
        )
        return [row[0] for row in rows]

    def counts(self) -> dict:
        """{'pending': n, 'ok': n, 'failed': n}."""
        counts = {"pending": 0, "ok": 0, "failed": 0}
        for status, count in self._connection.execute(
            "SELECT status, COUNT(*) FROM runs GROUP BY status"
        ):
            counts[status] = count
        return counts

    def meta(self) -> dict:
        """The campaign metadata (JSON values decoded where they were JSON)."""
        meta = {}
        for key, value in self._connection.execute("SELECT key, value FROM meta"):
            try:
                meta[key] = json.loads(value) if key in ("grid", "run_count") else value
            except json.JSONDecodeError:
                meta[key] = value
        return meta

    def rows(self) -> list[dict]:
        """Every run as a dict, JSON columns decoded, in plan order."""
        cursor = self._connection.execute("SELECT * FROM runs ORDER BY plan_index")
        names = [column[0] for column in cursor.description]
        rows = []
        for values in cursor:
            row = dict(zip(names, values))
            for key in ("grid_point", "overrides", "metrics"):
                if row[key] is not None:
                    row[key] = json.loads(row[key])
            rows.append(row)
        return rows
