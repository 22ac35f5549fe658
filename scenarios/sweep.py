"""The campaign engine: runs a planned campaign on Dask and writes each result as it arrives.

Owns: choosing the cluster, submitting the runs, recording results, the progress line, and
stopping cleanly. By default it starts a local cluster on this machine: one process per core,
one thread each, on 127.0.0.1. With `scheduler=` it uses an existing Dask distributed cluster.
Does not own: the plan (campaign.py), the per-run process and its timeout (harness.py), or the
store's format (store.py).

Order of work, so that bad input starts nothing and a refusal comes before any cluster:
1. The plan is built and every run is validated (campaign.plan_runs); --workers and
   --timeout-s are checked.
2. An existing store must be sound (SQLite's quick_check, read-only) and hold the same plan.
3. The output folder is made (an --out that is a file, lies under one, or cannot be written
   is refused) and locked (fcntl on OUT/.sweep.lock: one driver per folder).
4. The cluster is reached, or started. An unreachable scheduler, or one with no workers, is
   an error, and the folder and lock made in step 3 are removed again.
5. The store is opened and the pending runs are submitted.

The local cluster. Its scheduler, nannies and workers talk TLS, with a self-signed certificate
made in memory for this sweep (`distributed.security.Security.temporary()`), which every one
of them requires of its peers: another local user cannot connect a client and run code in the
workers. None of them starts an HTTP server (Dask starts one even with the dashboard off:
metrics and health routes, on 127.0.0.1:8787 for the scheduler). An external cluster
(`--scheduler`) is what its owner made it: Dask's protocol unpickles what the scheduler sends,
so name only a cluster you trust.

Submission keeps a bounded window of runs in flight: twice the cluster's threads, at least 8.
So the driver's memory and the scheduler's task count stay small for 100,000-run campaigns,
and a stop leaves little work to throw away. Each result is committed to SQLite when it
arrives. Resuming is running the same command again: the runs still `pending` in the store
are all that is submitted (with `retry_failed`, the failed ones are set back to pending first,
their failures kept in the store's `retries` table).

Failures, and where they are caught:
- The run raises: the runner records it (harness.py).
- The run hangs past the timeout, or kills its run process: the worker records it
  (harness.py).
- The run's worker process dies: Dask reschedules the run on another worker. After
  `distributed.scheduler.allowed-failures` deaths (Dask's default is 3; it is the scheduler's
  setting), the future raises KilledWorker, and the run is recorded failed here. Dask counts
  a death against every run the worker held. So the local cluster's scheduler is made with
  worker-saturation 1.0, and a worker holds only the run it is running.
- The scheduler is lost (an external cluster): Dask cancels the runs in flight. The driver
  stops (exit 1), and they stay pending for the rerun.
- Ctrl-C (or SIGTERM): submitting stops, runs in flight are cancelled, the cluster is closed,
  and every committed result stays. Runs in flight are pending again and run on resume. One
  that arrives while the local cluster starts is kept until it has started, then honoured the
  same way. The workers never see the terminal's Ctrl-C: they start with SIGINT blocked and
  then ignore it (harness.LocalWorker).
- At the end, and on a stop, the WAL is checkpointed: results.sqlite alone holds every result.
"""

import contextlib
import dataclasses
import datetime
import logging
import math
import os
import pathlib
import signal
import sys
import time
import traceback
import uuid
from collections import deque

from rpod.scenarios.campaign import Campaign, PlannedRun, base_fingerprint
from rpod.scenarios.loader import ScenarioFileError
from rpod.scenarios.run_progress import bar_size
from rpod.scenarios.store import (
    STORE_NAME,
    ResultStore,
    make_folder,
    mission_success,
    plan_fingerprint,
    remove_folders,
    store_path,
)

LOCK_NAME = ".sweep.lock"
DEFAULT_CONNECT_TIMEOUT_S = 10.0
MIN_WINDOW = 8
# Local workers allowed per core this process may use: each is a process with a runner child,
# and the driver's memory grows with every worker it starts.
MAX_WORKERS_PER_CORE = 4


@dataclasses.dataclass
class SweepOutcome:
    """What `run_campaign` did.

    Attributes:
        counts: runs per status in the store at the end ('ok', 'failed', 'pending').
        ran: runs recorded by this call (the others were recorded by earlier calls).
        interrupted: True when stopped by Ctrl-C / SIGTERM before the end.
        lost_scheduler: True when the cluster dropped runs (they stay pending).
        startup_s: time to reach or start the cluster.
        run_phase_s: time from the first submission to the last result.
        first_result_s: time from the first submission to the first result (it includes
            starting the runners); None if no result came.
        store: the store file.
    """

    counts: dict
    ran: int
    interrupted: bool
    lost_scheduler: bool
    startup_s: float
    run_phase_s: float
    store: pathlib.Path
    first_result_s: float | None = None


class Progress:
    """Runs done / failed / remaining, mission success so far, rate and ETA, on stderr.

    Mission success counts the finished runs with a verdict (rpod.scenarios.report
    .mission_success): a run that ran is not a run that succeeded.

    On a terminal it is a progress bar (tqdm): the counts and the mission success first, then
    the bar, the ETA and the rate; kept on screen when the sweep ends. Otherwise (a log file,
    CI) a plain line is written per update, at most one a second, and always the last one.
    """

    def __init__(self, label: str, total: int, ok: int, failed: int, stream=None):
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.label, self.total, self.ok, self.failed = label, total, ok, failed
        self.successes = self.judged = 0
        self._done_before = ok + failed
        self._start = time.monotonic()
        self._last_write = float("-inf")
        self._bar = None
        if self.tty:
            from tqdm import tqdm

            self._bar = tqdm(
                total=total,
                initial=self._done_before,
                desc=label,
                unit="run",
                # The counts and the mission success first: tqdm cuts a line at the terminal's
                # width, and they matter more than the timings (tqdm puts ", " before them).
                bar_format="{desc}: {n_fmt}/{total_fmt} runs{postfix} |{bar}| "
                "{percentage:3.0f}% [{elapsed}<{remaining}, {rate_fmt}]",
                file=self.stream,
                **bar_size(),
                smoothing=0.05,  # the rate over many runs: their lengths differ widely
            )

    def judge(self, rows) -> None:
        """Counts the mission verdicts of finished runs (store rows or run results)."""
        for row in rows:
            verdict = mission_success(row)
            if verdict is not None:
                self.judged += 1
                self.successes += verdict

    def _success(self) -> str:
        if not self.judged:
            return "mission success --"
        share = 100.0 * self.successes / self.judged
        return f"mission success {share:.1f}% ({self.successes}/{self.judged})"

    def update(self, ok: int, failed: int, final: bool = False) -> None:
        self.ok, self.failed = ok, failed
        done = ok + failed
        left = self.total - done
        if self.tty:
            if self._bar is None:  # closed by the final update
                return
            self._bar.update(done - self._bar.n)
            self._bar.set_postfix_str(f"{failed} failed | {self._success()}")
            if final:
                self._bar.close()
                self._bar = None
            return
        now = time.monotonic()
        if not (final or now - self._last_write >= 1.0):
            return
        self._last_write = now
        rate = (done - self._done_before) / max(now - self._start, 1e-9)
        if left == 0:
            eta = "0:00:00"
        else:
            eta = str(datetime.timedelta(seconds=round(left / rate))) if rate > 0 else "--"
        width = 20
        filled = int(width * done / self.total) if self.total else width
        line = (
            f"{self.label} [{'#' * filled}{'.' * (width - filled)}] {done}/{self.total} done"
            f", {failed} failed, {left} left | {self._success()} | {rate:.2f} runs/s | ETA {eta}"
        )
        self.stream.write(line + "\n")
        self.stream.flush()


def usable_cores() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0))


def check_workers(workers: int | None) -> None:
    """ScenarioFileError when --workers asks for more than MAX_WORKERS_PER_CORE per core."""
    limit = MAX_WORKERS_PER_CORE * usable_cores()
    if workers is not None and workers > limit:
        raise ScenarioFileError(
            f"--workers {workers}: above the limit of {limit} ({MAX_WORKERS_PER_CORE} x the "
            f"{usable_cores()} cores this process may use)"
        )


class _StopSignals:
    """SIGINT and SIGTERM stop the sweep with KeyboardInterrupt (SIGTERM as Ctrl-C does).

    While `deferred()` (the local cluster starting) they are only remembered, and
    `raise_if_requested()` raises once the cluster exists, so that it can be closed.
    """

    def __init__(self):
        self.deferring = False
        self.requested = False

    def __call__(self, signum, frame):
        if self.deferring:
            self.requested = True
            return
        raise KeyboardInterrupt()

    @contextlib.contextmanager
    def installed(self):
        try:
            previous = {s: signal.signal(s, self) for s in (signal.SIGINT, signal.SIGTERM)}
        except ValueError:  # not the main thread: signals are not ours to handle
            yield
            return
        try:
            yield
        finally:
            for signum, handler in previous.items():
                signal.signal(signum, handler)

    @contextlib.contextmanager
    def deferred(self):
        """Remembers stops; blocks SIGINT in this thread, so what starts inside inherits it
        blocked (threads, and worker processes, which then ignore it)."""
        self.deferring = True
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            yield
        finally:
            if signal.SIGINT in signal.sigpending():
                signal.sigtimedwait({signal.SIGINT}, 0)
                self.requested = True
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
            self.deferring = False

    def raise_if_requested(self) -> None:
        if self.requested:
            self.requested = False
            raise KeyboardInterrupt()


def _quiet_dask() -> None:
    for name in ("distributed", "distributed.client"):  # Dask sets both levels
        logging.getLogger(name).setLevel(logging.ERROR)


def _start_local_cluster(workers: int | None, stop: _StopSignals):
    """(client, cluster) on 127.0.0.1: TLS with a temporary certificate, no HTTP servers.

    A stop (Ctrl-C, SIGTERM) while it starts is deferred (see _StopSignals); the caller raises
    it once the cluster exists, or when starting failed because of it.
    """
    from multiprocessing import resource_tracker

    import dask
    from distributed import Client, Nanny, Scheduler, SpecCluster
    from distributed.security import Security

    from rpod.scenarios.harness import LocalWorker

    class LocalScheduler(Scheduler):
        def start_http_server(self, *args, **kwargs):
            """None: the scheduler starts one even without a dashboard (port 8787)."""

    _quiet_dask()
    count = workers or usable_cores()
    security = Security.temporary()  # in memory: a key pair and a self-signed certificate
    common = {"host": "127.0.0.1", "protocol": "tls://", "security": security}
    scheduler = {
        "cls": LocalScheduler,
        "options": {**common, "port": 0, "dashboard": False, "dashboard_address": None},
    }
    worker = {
        "cls": Nanny,
        "options": {
            **common,
            "worker_class": LocalWorker,
            "nthreads": 1,
            "memory_limit": 1.0 / count,  # a share of this machine's memory, as LocalCluster
            "dashboard": False,
            "dashboard_address": None,
            "silence_logs": logging.CRITICAL,
        },
    }
    # The worker processes must start with SIGINT blocked (stop.deferred), so they must be
    # spawned from threads that block it. multiprocessing's resource tracker, when the first
    # process spawned starts it, unblocks SIGINT in the spawning thread: start it before.
    resource_tracker.ensure_running()
    # worker-saturation 1.0: a worker holds only the run it is running (Dask's default, 1.1,
    # gives a 1-thread worker two). When a worker dies, Dask counts a death against every run
    # the worker held, so this keeps the runs queued next to a run that kills its worker from
    # being failed with it. The scheduler reads it when it is made (it runs in this process).
    with stop.deferred(), dask.config.set({"distributed.scheduler.worker-saturation": 1.0}):
        cluster = SpecCluster(
            scheduler=scheduler,
            workers={index: worker for index in range(count)},
            worker=worker,
            security=security,
            silence_logs=logging.CRITICAL,
        )
        try:
            return Client(cluster), cluster
        except BaseException:
            cluster.close(timeout=20)
            raise


def _cut(text, limit: int = 200) -> str:
    """text on one line, cut to `limit` characters (an address or a detail in an error line)."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _probe_scheduler(scheduler: str, timeout_s: float) -> None:
    """Returns once a Dask server at the address has answered Dask's handshake; raises
    TimeoutError when none has within timeout_s, or the error of the attempt (OSError,
    ValueError for a bad address, ...).

    `distributed.Client(address, timeout=...)` bounds the TCP connect but not the handshake
    read after it (distributed.comm.core.connect awaits `comm.read()` with no timeout): a port
    that accepts and says nothing (a plain TCP server, an HTTP server waiting for a request)
    kept `rpod sweep --scheduler` waiting forever. This attempt has one deadline for all of it,
    in an event loop of its own, before the Client is made.
    """
    import asyncio

    from distributed.comm import connect
    from distributed.security import Security

    async def attempt():
        comm = await connect(
            scheduler, timeout=timeout_s, **Security().get_connection_args("client")
        )
        await comm.close()

    async def bounded():
        await asyncio.wait_for(attempt(), timeout_s)

    asyncio.run(bounded())


def _accepts_connections(scheduler: str, timeout_s: float) -> bool:
    """True when a TCP connection to the (tcp:// or tls://) address is accepted."""
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(scheduler)
        if scheme not in ("tcp", "tls"):
            return False
        with socket.create_connection(parse_host_port(location), timeout=timeout_s):
            return True
    except (OSError, ValueError):
        return False


def _connect_scheduler(scheduler: str, connect_timeout_s: float):
    """A client of an existing scheduler; ScenarioFileError when it cannot be used, within
    about connect_timeout_s whatever is at the address (see _probe_scheduler)."""
    from distributed import Client

    _quiet_dask()
    label = f"--scheduler {_cut(scheduler)}"
    try:
        _probe_scheduler(scheduler, connect_timeout_s)
        client = Client(scheduler, timeout=connect_timeout_s)
    except Exception as error:  # noqa: BLE001 - OSError, TimeoutError, ValueError (bad address)
        if isinstance(error, TimeoutError) and _accepts_connections(
            scheduler, min(connect_timeout_s, 2.0)
        ):
            raise ScenarioFileError(
                f"{label}: not a Dask scheduler: something accepts connections there but did "
                f"not answer as one within {connect_timeout_s:g} s"
            ) from None
        detail = (str(error).strip().splitlines() or [type(error).__name__])[0]
        raise ScenarioFileError(
            f"{label}: no Dask scheduler answered within {connect_timeout_s:g} s "
            f"({_cut(detail, 120)})"
        ) from None
    try:
        client.wait_for_workers(1, timeout=connect_timeout_s)
    except Exception:  # noqa: BLE001 - a timeout, or the scheduler went away
        client.close()
        raise ScenarioFileError(
            f"{label}: the scheduler has no workers (none joined within {connect_timeout_s:g} s)"
        ) from None
    return client


@contextlib.contextmanager
def _folder_lock(out_dir: pathlib.Path):
    """One driver per output folder (released by the OS even on SIGKILL)."""
    import fcntl

    path = out_dir / LOCK_NAME
    try:
        handle = open(path, "a+")  # noqa: SIM115 - held for the whole sweep
    except OSError as error:
        raise ScenarioFileError(
            f"--out {out_dir}: cannot create the lock file {LOCK_NAME}: {error.strerror or error}"
        ) from None
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            # A driver that made this folder and then failed removes the lock file: the file
            # locked must still be the one at the path.
            locked = os.stat(path).st_ino == os.fstat(handle.fileno()).st_ino
        except (BlockingIOError, FileNotFoundError):
            locked = False
        except OSError as error:  # a file system without locks
            raise ScenarioFileError(
                f"--out {out_dir}: cannot lock {LOCK_NAME}: {error.strerror or error}"
            ) from None
        if not locked:
            raise ScenarioFileError(
                f"--out {out_dir}: another `rpod sweep` is writing to this folder"
            )
        yield


def _outcome(future) -> dict | None:
    """The result record of a finished future; None if the cluster cancelled it."""
    from distributed import KilledWorker

    if future.status == "finished":
        return future.result()
    if future.status == "error":
        error = future.exception()
        if isinstance(error, KilledWorker):
            first = (str(error).split(". ") or [""])[0]
            return {
                "status": "failed",
                "reason": "worker died: every worker that ran it died (Dask "
                f"allowed-failures exhausted): {first}",
                "detail": str(error),
            }
        text = "".join(traceback.format_exception(type(error), error, future.traceback()))
        return {
            "status": "failed",
            "reason": f"error: {type(error).__name__}: {(str(error).splitlines() or [''])[0]}",
            "detail": text[-4000:],
        }
    return None  # cancelled: the scheduler lost it; it stays pending


def _requests(
    campaign: Campaign,
    runs: list[PlannedRun],
    out_dir: pathlib.Path,
    timeout_s: float | None,
    save_runs: bool,
    record: bool,
):
    base_yaml = campaign.base_yaml
    runs_dir = (out_dir / "runs").resolve()

    def request(run: PlannedRun) -> dict:
        return {
            "run_id": run.run_id,
            "case": run.case,
            "base_yaml": base_yaml,
            "overrides": run.overrides,
            "timeout_s": timeout_s,
            "save_dir": str(runs_dir / run.run_id) if (save_runs or record) else None,
            "record": record,
        }

    return request


def run_campaign(
    campaign: Campaign,
    runs: list[PlannedRun],
    out_dir: pathlib.Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    timeout_s: float | None = None,
    save_runs: bool = False,
    record: bool = False,
    retry_failed: bool = False,
    reuse: pathlib.Path | None = None,
    connect_timeout_s: float = DEFAULT_CONNECT_TIMEOUT_S,
    progress_stream=None,
) -> SweepOutcome:
    """Runs every pending run of a planned campaign; see the module docstring.

    Raises ScenarioFileError on bad input (nothing is started then), and KeyboardInterrupt
    when stopped before the store was opened (a stop later returns interrupted=True).

    Args:
        campaign: the loaded campaign (its base scenario goes to the workers as YAML).
        runs: campaign.plan_runs(campaign).
        out_dir: output folder; the store is out_dir/results.sqlite.
        scheduler: address of an existing Dask scheduler, or None for a local cluster.
        workers: local worker processes (default: the cores this process may use; at most
            MAX_WORKERS_PER_CORE per core).
        timeout_s: per-run limit (None: none).
        save_runs: also write each run's outputs (log.npz, plots, summary) to out_dir/runs/<id>/;
            with a remote cluster out_dir must be on a file system the workers share.
        record: also write each run's Meshcat recording (implies save_runs).
        retry_failed: set the failed runs back to pending and run them again.
        reuse: another campaign's results folder: its finished runs whose ids are planned here
            are recorded as they are instead of flown again (ResultStore.reuse; the id is the
            run's whole scenario, the result that of the code that flew it there).
        connect_timeout_s: how long to wait for the scheduler and its first worker.
        progress_stream: where the progress line goes (default stderr).
    """
    check_workers(workers)
    if timeout_s is not None and not 0 < timeout_s < math.inf:
        raise ScenarioFileError(
            f"--timeout-s {timeout_s:g}: expected a positive, finite number of seconds"
        )
    out_dir = pathlib.Path(out_dir)
    store_file = out_dir / STORE_NAME
    if reuse is not None:  # a clear error before anything runs
        try:
            with ResultStore.open_existing(reuse) as other:
                other.check()
        except ScenarioFileError as error:
            raise ScenarioFileError(f"--reuse: {error}") from None
        reuse = store_path(pathlib.Path(reuse))
        if reuse.resolve() == store_file.resolve():
            raise ScenarioFileError(f"--reuse {reuse.parent}: is the --out folder itself")
    ResultStore.check_compatible(store_file, plan_fingerprint(r.run_id for r in runs), len(runs))
    made = make_folder(out_dir)
    stop = _StopSignals()
    try:
        with stop.installed(), _folder_lock(out_dir):
            return _run_locked(
                campaign,
                runs,
                out_dir,
                stop,
                scheduler=scheduler,
                workers=workers,
                timeout_s=timeout_s,
                save_runs=save_runs,
                record=record,
                retry_failed=retry_failed,
                reuse=reuse,
                connect_timeout_s=connect_timeout_s,
                progress_stream=progress_stream,
            )
    except (ScenarioFileError, KeyboardInterrupt):
        if made and not store_file.exists():  # nothing was stored: leave nothing behind
            with contextlib.suppress(OSError):
                (out_dir / LOCK_NAME).unlink()
            remove_folders(made)
        raise


def _run_locked(
    campaign: Campaign,
    runs: list[PlannedRun],
    out_dir: pathlib.Path,
    stop: _StopSignals,
    *,
    scheduler,
    workers,
    timeout_s,
    save_runs,
    record,
    retry_failed,
    reuse,
    connect_timeout_s,
    progress_stream,
) -> SweepOutcome:
    """run_campaign once the folder is locked: the cluster, the store and the runs."""
    store_file = out_dir / STORE_NAME
    if store_file.exists() and reuse is None:
        with ResultStore(store_file) as store:
            counts = store.counts()
            left = counts["pending"] + (counts["failed"] if retry_failed else 0)
            if left == 0 and sum(counts.values()) == len(runs):  # nothing to run: no cluster
                store.checkpoint()
                progress = Progress(
                    campaign.name, len(runs), counts["ok"], counts["failed"], progress_stream
                )
                progress.judge(store.rows())
                progress.update(counts["ok"], counts["failed"], final=True)
                return SweepOutcome(counts, 0, False, False, 0.0, 0.0, store_file)

    started = time.perf_counter()
    client = cluster = None
    try:
        if scheduler is None:
            try:
                client, cluster = _start_local_cluster(workers, stop)
            except Exception:
                stop.raise_if_requested()  # it failed because of the stop (workers interrupted)
                raise
            stop.raise_if_requested()  # a stop while it started: honoured now it exists
        else:
            client = _connect_scheduler(scheduler, connect_timeout_s)
        startup_s = time.perf_counter() - started
        with ResultStore(store_file) as store:
            try:
                return _submit_all(
                    campaign,
                    runs,
                    out_dir,
                    store,
                    client,
                    startup_s,
                    timeout_s=timeout_s,
                    save_runs=save_runs,
                    record=record,
                    retry_failed=retry_failed,
                    reuse=reuse,
                    progress_stream=progress_stream,
                )
            finally:  # results.sqlite alone then holds every result (store.py, "On disk")
                with contextlib.suppress(ScenarioFileError):
                    store.checkpoint()
    finally:
        # Closing after a lost scheduler makes Dask log its reconnect's cancellation as an
        # error with a traceback; what matters was said above, and the store keeps the rest.
        for name in ("distributed", "distributed.client"):  # Dask sets both levels
            logging.getLogger(name).setLevel(logging.CRITICAL)
        if client is not None:
            with contextlib.suppress(Exception):
                client.close(timeout=10)
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close(timeout=20)


def _submit_all(
    campaign: Campaign,
    runs: list[PlannedRun],
    out_dir: pathlib.Path,
    store: ResultStore,
    client,
    startup_s: float,
    *,
    timeout_s,
    save_runs,
    record,
    retry_failed,
    reuse,
    progress_stream,
) -> SweepOutcome:
    """Writes the plan, then keeps a window of pending runs in flight and records each result."""
    from distributed import as_completed

    from rpod.scenarios.harness import run_case

    interrupted = lost = False
    ran, first_result_s = 0, None
    store.write_plan(
        {
            "campaign_name": campaign.name,
            "campaign_source": campaign.source,
            "campaign_text": campaign.text,
            "base_name": campaign.base_name,
            "base_yaml": campaign.base_yaml,
            "base_fingerprint": base_fingerprint(campaign),
            "grid": campaign.grid,
            "run_count": len(runs),
        },
        runs,
    )
    if reuse is not None:
        with ResultStore.open_existing(reuse) as other:
            reused = store.reuse(other, str(reuse.parent))
        print(
            f"{campaign.name}: {reused} finished runs reused from {reuse.parent} (not flown again)",
            file=progress_stream or sys.stderr,
        )
    if retry_failed:
        store.retry_failed()
    by_id = {run.run_id: run for run in runs}
    queue = deque(store.pending_ids())
    counts = store.counts()
    progress = Progress(campaign.name, len(runs), counts["ok"], counts["failed"], progress_stream)
    progress.judge(row for row in store.rows() if row["status"] != "pending")
    progress.update(counts["ok"], counts["failed"], final=not queue)
    request = _requests(campaign, runs, out_dir, timeout_s, save_runs, record)
    in_flight = {}
    completed = as_completed()
    window, window_checked = MIN_WINDOW, float("-inf")

    def submit_more():
        nonlocal window, window_checked
        if time.monotonic() - window_checked > 5.0:
            window = max(MIN_WINDOW, 2 * sum(client.nthreads().values()))
            window_checked = time.monotonic()
        while queue and len(in_flight) < window:
            run_id = queue.popleft()
            future = client.submit(
                run_case,
                request(by_id[run_id]),
                pure=False,
                key=f"rpod-run-{run_id}-{uuid.uuid4().hex[:8]}",
            )
            in_flight[future] = run_id
            completed.add(future)

    run_phase_start = time.perf_counter()
    try:
        submit_more()
        for future in completed:
            run_id = in_flight.pop(future)
            result = _outcome(future)
            future.release()
            if result is None:
                lost = True
                break
            if first_result_s is None:
                first_result_s = time.perf_counter() - run_phase_start
            if store.record(run_id, result):
                ran += 1
                key = "ok" if result["status"] == "ok" else "failed"
                counts[key] += 1
                counts["pending"] -= 1
                progress.judge([result])
            progress.update(counts["ok"], counts["failed"], final=counts["pending"] == 0)
            submit_more()
    except KeyboardInterrupt:
        interrupted = True
    finally:
        if in_flight:
            with contextlib.suppress(Exception):
                client.cancel(list(in_flight))
    run_phase_s = time.perf_counter() - run_phase_start
    if interrupted or lost:
        progress.update(counts["ok"], counts["failed"], final=True)
    counts = store.counts()
    return SweepOutcome(
        counts, ran, interrupted, lost, startup_s, run_phase_s, store.path, first_result_s
    )
