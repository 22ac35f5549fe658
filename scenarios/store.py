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

On disk. Between sweeps the store is the one file `results.sqlite`: a sweep checkpoints the WAL
into it when it ends or is interrupted (Ctrl-C, SIGTERM). While a sweep runs, or after one was
SIGKILLed, the latest results may be only in `results.sqlite-wal` (with `results.sqlite-shm`), so
copy the folder, not the file; rerunning the sweep checkpoints them.

Reading never writes. `open_existing` opens the file read-only: with `mode=ro` when a `-wal` file
is there (it holds committed results), else `immutable=1`, which reads the file alone and creates
no `-wal` or `-shm` beside it (so a store on a read-only disk can be read). An empty, truncated
or damaged file is a ScenarioFileError, whichever statement finds the damage.

Schema (`runs`): run_id (primary key), plan_index, grp (group label), case_name, grid_point
(JSON), sample_index, overrides (JSON), status ('pending' | 'ok' | 'failed'), reason (one line:
why it failed), detail (traceback or stderr tail), metrics (JSON: the run's summary),
wall_time_s (the worker-side time of the run), worker, finished_at (UTC, ISO 8601).
`meta` holds the campaign's name, source text, base scenario YAML, grid and plan fingerprint.
`retries` keeps the reason, detail, worker and finish time of each failure that
`rpod sweep --retry-failed` set back to pending, with the time it did so (retried_at).
"""

import contextlib
import datetime
import hashlib
import json
import math
import os
import pathlib
import shlex
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
CREATE TABLE IF NOT EXISTS retries (
    run_id TEXT NOT NULL,
    reason TEXT,
    detail TEXT,
    worker TEXT,
    finished_at TEXT,
    retried_at TEXT NOT NULL
);
"""


def plan_fingerprint(run_ids) -> str:
    """A hash of the set of run ids: two plans with the same runs have the same fingerprint."""
    return hashlib.sha256("\n".join(sorted(run_ids)).encode()).hexdigest()


def _q(path) -> str:
    """A path for an error line: whole up to 200 characters, then cut ("...")."""
    text = " ".join(str(path).split())
    return text if len(text) <= 200 else text[:197] + "..."


def store_path(results: pathlib.Path) -> pathlib.Path:
    """The store file of a campaign output folder (or the file itself)."""
    results = pathlib.Path(results)
    return results / STORE_NAME if results.is_dir() or not results.suffix else results


def _now() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="milliseconds")


def _wal(path: pathlib.Path) -> pathlib.Path:
    return path.with_name(path.name + "-wal")


def _file_state(path: pathlib.Path):
    """What changes when a writer touches the store: the file's identity, size and mtime."""
    stat = path.stat()
    return stat.st_ino, stat.st_size, stat.st_mtime_ns, _wal(path).exists()


def make_folder(path: pathlib.Path, flag: str = "--out") -> list[pathlib.Path]:
    """Creates an output folder (and its parents); the folders it made, outermost first.

    ScenarioFileError naming the flag when the path is a file, lies under a file, or cannot be
    made (no permission, a read-only or virtual file system).
    """
    path = pathlib.Path(path)
    made = []
    try:
        for parent in [path, *path.parents]:
            if parent.exists() or parent.is_symlink():
                if not parent.is_dir():
                    where = "" if parent == path else f"{_q(parent)} "
                    raise ScenarioFileError(f"{flag} {_q(path)}: {where}is not a folder")
                break
        made = [p for p in reversed([path, *path.parents]) if not p.exists()]
        path.mkdir(parents=True, exist_ok=True)
    except OSError as error:  # no permission, a read-only file system, a name too long
        remove_folders(made)
        raise ScenarioFileError(
            f"{flag} {_q(path)}: cannot create the folder: {error.strerror or error}"
        ) from None
    if not os.access(path, os.W_OK | os.X_OK):
        remove_folders(made)
        raise ScenarioFileError(f"{flag} {_q(path)}: cannot write to the folder (no permission)")
    return made


def remove_folders(folders: list[pathlib.Path]) -> None:
    """Removes folders that make_folder made, innermost first, if they are still empty."""
    for folder in reversed(folders):
        with contextlib.suppress(OSError):
            folder.rmdir()


class ResultStore:
    """An open results store. Every write is its own transaction, committed before returning.

    `ResultStore(path)` opens (or creates) it for writing: only `rpod sweep` does that, holding
    the folder's lock. `ResultStore.open_existing(results)` opens it read-only.
    """

    def __init__(self, path: pathlib.Path, read_only: bool = False, use_wal: bool = False):
        self.path = pathlib.Path(path)
        self.read_only = read_only
        self._state = None
        with self._guard("open"):
            if not read_only:
                self._connection = sqlite3.connect(self.path, timeout=30.0)
                self._connection.execute("PRAGMA journal_mode=WAL")
                self._connection.execute("PRAGMA synchronous=NORMAL")
                with self._connection:
                    self._connection.executescript(_SCHEMA)
            elif use_wal or _wal(self.path).exists():  # committed results may be in the WAL
                uri = f"{self.path.resolve().as_uri()}?mode=ro"
                self._connection = sqlite3.connect(uri, uri=True, timeout=30.0)
            else:  # the file alone holds everything; read it without a -wal or -shm beside it
                self._state = _file_state(self.path)
                uri = f"{self.path.resolve().as_uri()}?immutable=1"
                self._connection = sqlite3.connect(uri, uri=True)

    @contextlib.contextmanager
    def _guard(self, action: str = "read"):
        """SQLite errors (a damaged, truncated or foreign file; a full disk) -> one line."""
        try:
            yield
        except sqlite3.DatabaseError as error:
            raise ScenarioFileError(
                f"{self.path}: cannot {action} the results store: {error}"
            ) from None

    @classmethod
    def open_existing(cls, results, use_wal: bool = False) -> "ResultStore":
        """The store of an output folder (or file), read-only; ScenarioFileError if it is not one.

        Args:
            results: a campaign output folder or its results.sqlite.
            use_wal: open with mode=ro even when there is no -wal file (see `changed`).
        """
        try:
            path = store_path(results)
            is_file = path.is_file()
        except OSError as error:  # e.g. a name too long
            raise ScenarioFileError(f"{_q(results)}: cannot be read: {error.strerror}") from None
        if not is_file:
            raise ScenarioFileError(f"{_q(results)}: no results store ({STORE_NAME}) there")
        store = cls(path, read_only=True, use_wal=use_wal)
        try:
            with store._guard():
                tables = {
                    row[0]
                    for row in store._connection.execute(
                        "SELECT name FROM sqlite_master WHERE type = 'table'"
                    )
                }
            if not {"meta", "runs"} <= tables:
                what = "an empty file" if path.stat().st_size == 0 else "it has no runs table"
                raise ScenarioFileError(f"{path}: not a results store ({what})")
        except BaseException:
            store.close()
            raise
        return store

    def changed(self) -> bool:
        """True when a read-only store opened without its WAL was written meanwhile (read it
        again with use_wal=True)."""
        return self._state is not None and _file_state(self.path) != self._state

    def check(self) -> None:
        """ScenarioFileError unless SQLite's quick_check finds every page sound."""
        with self._guard():
            result = self._connection.execute("PRAGMA quick_check").fetchall()
        if result != [("ok",)]:
            raise ScenarioFileError(
                f"{self.path}: cannot read the results store: damaged ({result[0][0]})"
            )

    @staticmethod
    def check_compatible(path: pathlib.Path, fingerprint: str, run_count: int) -> None:
        """ScenarioFileError if an existing store at path is damaged or holds a different plan."""
        try:
            if not path.exists():
                return
            is_file = path.is_file()
        except OSError as error:  # e.g. a name too long
            raise ScenarioFileError(f"--out {_q(path.parent)}: cannot be used: {error.strerror}")
        if not is_file:
            raise ScenarioFileError(f"{_q(path)}: --out: is not a results store file")
        with ResultStore.open_existing(path) as store:
            store.check()
            stored, stored_count = store.fingerprint(), store.run_count()
        if stored is not None and stored != fingerprint:
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

    def fingerprint(self) -> str | None:
        """The stored plan's fingerprint (None before a plan was written)."""
        with self._guard():
            row = self._connection.execute(
                "SELECT value FROM meta WHERE key = 'plan_fingerprint'"
            ).fetchone()
        return None if row is None else row[0]

    def run_count(self) -> int:
        with self._guard():
            return self._connection.execute("SELECT COUNT(*) FROM runs").fetchone()[0]

    def write_plan(self, meta: dict, runs) -> None:
        """Stores the campaign's metadata and inserts every planned run not already there."""
        fingerprint = plan_fingerprint(r.run_id for r in runs)
        stored = self.fingerprint()
        if stored is not None and stored != fingerprint:  # another plan got here first
            raise ScenarioFileError(
                f"{self.path}: --out: holds the results of a different plan; choose another --out"
            )
        rows = (
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
        )
        meta = {**meta, "schema_version": SCHEMA_VERSION, "plan_fingerprint": fingerprint}
        with self._guard("write"), self._connection:
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
        with self._guard("write"), self._connection:
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
                    _now(),
                    run_id,
                ),
            )
        return cursor.rowcount == 1

    def reuse(self, other: "ResultStore", label: str) -> int:
        """Records, for every run still pending here, the finished result that `other` holds
        for the same scenario (`counterparts`: the same run id, or, when both stores were
        planned on the same base (`same_base`), the same start to START_RTOL: two CPUs), its
        worker marked `reused from <label>`; how many. The results are those of the code (and
        the machine) that flew them into `other`."""
        pending = [row for row in self.rows() if row["status"] == "pending"]
        finished = [row for row in other.rows() if row["status"] in ("ok", "failed")]
        matches = counterparts(pending, finished, by_start=same_base(self.meta(), other.meta()))
        with self._guard("write"), self._connection:
            for run_id, row in matches.items():
                self._connection.execute(
                    "UPDATE runs SET status = ?, reason = ?, detail = ?, metrics = ?,"
                    " wall_time_s = ?, worker = ?, finished_at = ? WHERE run_id = ?"
                    " AND status = 'pending'",
                    (
                        row["status"],
                        row["reason"],
                        row["detail"],
                        json.dumps(row["metrics"]) if row["metrics"] is not None else None,
                        row["wall_time_s"],
                        f"reused from {label}",
                        row["finished_at"],
                        run_id,
                    ),
                )
        return len(matches)

    def retry_failed(self) -> int:
        """Sets every failed run back to pending, keeping its failure in `retries`; how many."""
        with self._guard("write"), self._connection:
            self._connection.execute(
                "INSERT INTO retries (run_id, reason, detail, worker, finished_at, retried_at) "
                "SELECT run_id, reason, detail, worker, finished_at, ? FROM runs "
                "WHERE status = 'failed'",
                (_now(),),
            )
            cursor = self._connection.execute(
                "UPDATE runs SET status = 'pending', reason = NULL, detail = NULL, metrics = NULL,"
                " wall_time_s = NULL, worker = NULL, finished_at = NULL WHERE status = 'failed'"
            )
        return cursor.rowcount

    def checkpoint(self) -> None:
        """Copies the WAL into results.sqlite and empties it: the file alone holds every result."""
        with self._guard("write"):
            self._connection.execute("PRAGMA wal_checkpoint(TRUNCATE)").fetchall()

    def pending_ids(self) -> list[str]:
        """Ids of the runs not yet recorded, in plan order."""
        with self._guard():
            rows = self._connection.execute(
                "SELECT run_id FROM runs WHERE status = 'pending' ORDER BY plan_index"
            )
            return [row[0] for row in rows]

    def counts(self) -> dict:
        """{'pending': n, 'ok': n, 'failed': n}."""
        counts = {"pending": 0, "ok": 0, "failed": 0}
        with self._guard():
            for status, count in self._connection.execute(
                "SELECT status, COUNT(*) FROM runs GROUP BY status"
            ):
                counts[status] = count
        return counts

    def meta(self) -> dict:
        """The campaign metadata (JSON values decoded where they were JSON)."""
        meta = {}
        with self._guard():
            for key, value in self._connection.execute("SELECT key, value FROM meta"):
                try:
                    meta[key] = json.loads(value) if key in ("grid", "run_count") else value
                except json.JSONDecodeError:
                    meta[key] = value
        return meta

    def rows(self) -> list[dict]:
        """Every run as a dict, JSON columns decoded, in plan order."""
        rows = []
        with self._guard():
            cursor = self._connection.execute("SELECT * FROM runs ORDER BY plan_index")
            names = [column[0] for column in cursor.description]
            for values in cursor:
                row = dict(zip(names, values))
                for key in ("grid_point", "overrides", "metrics"):
                    if row[key] is not None:
                        try:
                            row[key] = json.loads(row[key])
                        except json.JSONDecodeError as error:
                            raise sqlite3.DatabaseError(
                                f"run {row['run_id']}: {key} is not JSON ({error})"
                            ) from None
                rows.append(row)
        return rows


# Two planned runs are the same scenario when their overrides agree to this relative tolerance:
# a start sampled on another CPU differs in its last bits (numpy and OpenBLAS pick kernels by
# the CPU's vector extensions, so a norm or a product may round otherwise), and its run id,
# the hash of its overrides' text, with them.
START_RTOL = 1e-9
START_ATOL = 1e-12  # for values that are zero on one CPU and a rounding residue on another


def same_overrides(a, b) -> bool:
    """Whether two runs' overrides (decoded JSON) are the same scenario: equal in structure
    and text, their floats within START_RTOL (START_ATOL near zero)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same_overrides(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same_overrides(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float):
        return math.isclose(a, b, rel_tol=START_RTOL, abs_tol=START_ATOL)
    return type(a) is type(b) and a == b


def same_base(meta: dict, other_meta: dict) -> bool:
    """Whether two stores' plans share their base scenario as resolved by the code that
    planned them (`meta["base_fingerprint"]`, rpod.scenarios.campaign.base_fingerprint; a
    store written before it was recorded shares nothing)."""
    mine = meta.get("base_fingerprint")
    return mine is not None and mine == other_meta.get("base_fingerprint")


def counterparts(rows: list[dict], others: list[dict], by_start: bool = True) -> dict[str, dict]:
    """For each of rows (`ResultStore.rows()`), the row of others that is the same scenario:
    the one with the same run id, else (by_start: the two plans share their base, `same_base`)
    the one at the same place in the plan (group, case, grid point, sample) whose overrides
    are `same_overrides`; run id -> that row. Without a shared base, the same overrides may be
    another scenario (a default of the base changed), so only ids pair."""
    by_id = {row["run_id"]: row for row in others}
    by_place = {}
    for row in others:
        by_place.setdefault(_place(row), []).append(row)
    matches = {}
    for row in rows:
        match = by_id.get(row["run_id"])
        if match is None and by_start:
            match = next(
                (
                    other
                    for other in by_place.get(_place(row), ())
                    if same_overrides(other["overrides"], row["overrides"])
                ),
                None,
            )
        if match is not None:
            matches[row["run_id"]] = match
    return matches


def _place(row: dict) -> tuple:
    return (row["grp"], row["case_name"], json.dumps(row["grid_point"]), row["sample_index"])


def mission_success(row: dict) -> bool | None:
    """The run's mission verdict: True, False (a failed simulation is False), or None.

    None: the run is pending, or its scenario has no mission to judge (no controller or no
    criterion), or it was stored before rpod judged missions.
    """
    if row["status"] == "failed":
        return False
    if row["status"] != "ok" or not row["metrics"]:
        return None
    success = (row["metrics"].get("mission") or {}).get("success")
    return None if success is None else bool(success)


def contact_occurred(row: dict) -> bool:
    """Whether the run's true shapes touched (summary `contact.occurred`)."""
    return bool(((row["metrics"] or {}).get("contact") or {}).get("occurred"))


def rerun_command(meta: dict, results_folder: str, run_id: str) -> str:
    """The command that flies a stored run again with every output (`rpod sweep --rerun`).

    The campaign is named as the sweep was given it: a bundled campaign by its name (its file
    in a `bundled/campaigns` folder, wherever the package was), any other by its file's path.
    """
    name = meta.get("campaign_name") or "CAMPAIGN"
    source = meta.get("campaign_source")
    campaign = name
    if source:
        path = pathlib.PurePath(source)
        bundled = path.parent.name == "campaigns" and path.parent.parent.name == "bundled"
        campaign = name if bundled and path.stem == name else shlex.quote(source)
    return f"rpod sweep {campaign} --out {shlex.quote(results_folder)} --rerun {run_id}"
