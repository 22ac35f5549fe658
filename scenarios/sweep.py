"""The campaign engine: runs a planned campaign on Dask and writes each result as it arrives.

Owns: choosing the cluster, submitting the runs, recording results, the progress line, and
stopping cleanly. By default it starts a LocalCluster on this machine: one process per core,
one thread each, on 127.0.0.1. With `scheduler=` it uses an existing Dask distributed cluster.
Does not own: the plan (campaign.py), the per-run process and its timeout (harness.py), or the
store's format (store.py).

Order of work, so that bad input starts nothing:
1. The plan is built and every run is validated (campaign.plan_runs).
2. An existing store must hold the same plan.
3. The cluster is reached, or started. An unreachable scheduler, or one with no workers, is
   an error, and no folder has been made yet.
4. Then the output folder, a lock file (one driver per folder) and the store are made, and the
   pending runs are submitted.

Submission keeps a bounded window of runs in flight: twice the cluster's threads, at least 8.
So the driver's memory and the scheduler's task count stay small for 100,000-run campaigns,
and a stop leaves little work to throw away. Each result is committed to SQLite when it
arrives. Resuming is running the same command again: the runs still `pending` in the store
are all that is submitted.

Failures, and where they are caught:
- The run raises: the runner records it (harness.py).
- The run hangs past the timeout, or kills its run process: the worker records it
  (harness.py).
- The run's worker process dies: Dask reschedules the run on another worker. After
  `distributed.scheduler.allowed-failures` deaths (Dask's default is 3; it is the scheduler's
  setting), the future raises KilledWorker, and the run is recorded failed here. Dask counts
  a death against every run the worker held. So the LocalCluster's scheduler is made with
  worker-saturation 1.0, and a worker holds only the run it is running.
- The scheduler is lost (an external cluster): Dask cancels the runs in flight. The driver
  stops (exit 1), and they stay pending for the rerun.
- Ctrl-C (or SIGTERM): submitting stops, runs in flight are cancelled, the cluster is closed,
  and every committed result stays. Runs in flight are pending again and run on resume.
"""

import contextlib
import dataclasses
import datetime
import logging
import os
import pathlib
import shutil
import signal
import sys
import time
import traceback
import uuid
from collections import deque

from rpod.scenarios.campaign import Campaign, PlannedRun
from rpod.scenarios.loader import ScenarioFileError
from rpod.scenarios.store import STORE_NAME, ResultStore, plan_fingerprint

LOCK_NAME = ".sweep.lock"
DEFAULT_CONNECT_TIMEOUT_S = 10.0
MIN_WINDOW = 8


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
    """Runs done / failed / remaining, success rate and ETA, on stderr.

    On a terminal the line is redrawn in place. Otherwise (a log file, CI) a line is written
    per update, at most one a second, and always the last one.
    """

    def __init__(self, label: str, total: int, ok: int, failed: int, stream=None):
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.label, self.total, self.ok, self.failed = label, total, ok, failed
        self._done_before = ok + failed
        self._start = time.monotonic()
        self._last_write = float("-inf")

    def update(self, ok: int, failed: int, final: bool = False) -> None:
        self.ok, self.failed = ok, failed
        now = time.monotonic()
        if not (final or self.tty or now - self._last_write >= 1.0):
            return
        self._last_write = now
        done = ok + failed
        left = self.total - done
        rate = (done - self._done_before) / max(now - self._start, 1e-9)
        if left == 0:
            eta = "0:00:00"
        else:
            eta = str(datetime.timedelta(seconds=round(left / rate))) if rate > 0 else "--"
        success = f"{100.0 * ok / done:.1f}% ok" if done else "--% ok"
        width = 20
        filled = int(width * done / self.total) if self.total else width
        line = (
            f"{self.label} [{'#' * filled}{'.' * (width - filled)}] {done}/{self.total} done"
            f", {failed} failed, {left} left | {success} | {rate:.2f} runs/s | ETA {eta}"
        )
        if self.tty:  # one screen line, or "\r" could not redraw it
            line = line[: max(20, shutil.get_terminal_size().columns - 1)]
            self.stream.write("\r" + line + "\033[K" + ("\n" if final else ""))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


def _connect(scheduler: str | None, workers: int | None, connect_timeout_s: float):
    """(client, cluster or None); ScenarioFileError when the scheduler cannot be used."""
    import dask
    from distributed import Client, LocalCluster

    for name in ("distributed", "distributed.client"):  # Dask sets both levels
        logging.getLogger(name).setLevel(logging.ERROR)
    if scheduler is None:
        count = workers or len(os.sched_getaffinity(0))
        # Worker processes inherit SIGINT ignored, so that Ctrl-C reaches only the driver,
        # which then closes the cluster itself.
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            # worker-saturation 1.0: a worker holds only the run it is running (Dask's default,
            # 1.1, gives a 1-thread worker two). When a worker dies, Dask counts a death against
            # every run the worker held, so this keeps the runs queued next to a run that kills
            # its worker from being failed with it.
            # The scheduler reads it when it is made (it runs in this process).
            with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}):
                cluster = LocalCluster(
                    n_workers=count,
                    threads_per_worker=1,
                    processes=True,
                    host="127.0.0.1",
                    dashboard_address=None,
                    silence_logs=logging.CRITICAL,
                )
        finally:
            signal.signal(signal.SIGINT, previous)
        return Client(cluster), cluster
    try:
        client = Client(scheduler, timeout=connect_timeout_s)
    except Exception as error:  # OSError, TimeoutError, ValueError (bad address), ...
        detail = (str(error).strip().splitlines() or [type(error).__name__])[0]
        raise ScenarioFileError(
            f"--scheduler {scheduler}: no Dask scheduler answered within "
            f"{connect_timeout_s:g} s ({detail})"
        ) from None
    try:
        client.wait_for_workers(1, timeout=connect_timeout_s)
    except Exception:
        client.close()
        raise ScenarioFileError(
            f"--scheduler {scheduler}: the scheduler has no workers (none joined within "
            f"{connect_timeout_s:g} s)"
        ) from None
    return client, None


@contextlib.contextmanager
def _folder_lock(out_dir: pathlib.Path):
    """One driver per output folder (released by the OS even on SIGKILL)."""
    import fcntl

    with open(out_dir / LOCK_NAME, "a+") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise ScenarioFileError(
                f"{out_dir}: --out: another `rpod sweep` is writing to this folder"
            ) from None
        yield


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """SIGTERM stops the campaign as Ctrl-C does (only in the main thread)."""

    def handler(signum, frame):
        raise KeyboardInterrupt()

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


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
    connect_timeout_s: float = DEFAULT_CONNECT_TIMEOUT_S,
    progress_stream=None,
) -> SweepOutcome:
    """Runs every pending run of a planned campaign; see the module docstring.

    Args:
        campaign: the loaded campaign (its base scenario goes to the workers as YAML).
        runs: campaign.plan_runs(campaign).
        out_dir: output folder; the store is out_dir/results.sqlite.
        scheduler: address of an existing Dask scheduler, or None for a LocalCluster.
        workers: LocalCluster processes (default: the cores this process may use).
        timeout_s: per-run limit (None: none).
        save_runs: also write each run's outputs (log.npz, plots, summary) to out_dir/runs/<id>/;
            with a remote cluster out_dir must be on a file system the workers share.
        record: also write each run's Meshcat recording (implies save_runs).
        connect_timeout_s: how long to wait for the scheduler and its first worker.
        progress_stream: where the progress line goes (default stderr).
    """
    from distributed import as_completed

    from rpod.scenarios.harness import run_case

    out_dir = pathlib.Path(out_dir)
    store_file = out_dir / STORE_NAME
    fingerprint = plan_fingerprint(r.run_id for r in runs)
    ResultStore.check_compatible(store_file, fingerprint, len(runs))
    if store_file.is_file():
        with ResultStore(store_file) as store:
            counts = store.counts()
        if counts["pending"] == 0 and sum(counts.values()) == len(runs):  # nothing left to run
            Progress(
                campaign.name, len(runs), counts["ok"], counts["failed"], progress_stream
            ).update(counts["ok"], counts["failed"], final=True)
            return SweepOutcome(counts, 0, False, False, 0.0, 0.0, store_file)

    started = time.perf_counter()
    client, cluster = _connect(scheduler, workers, connect_timeout_s)
    startup_s = time.perf_counter() - started
    interrupted = lost = False
    ran, run_phase_s, first_result_s = 0, 0.0, None
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        with _folder_lock(out_dir), ResultStore(store_file) as store, _sigterm_as_interrupt():
            store.write_plan(
                {
                    "campaign_name": campaign.name,
                    "campaign_source": campaign.source,
                    "campaign_text": campaign.text,
                    "base_name": campaign.base_name,
                    "base_yaml": campaign.base_yaml,
                    "grid": campaign.grid,
                    "run_count": len(runs),
                },
                runs,
            )
            by_id = {run.run_id: run for run in runs}
            queue = deque(store.pending_ids())
            counts = store.counts()
            progress = Progress(
                campaign.name, len(runs), counts["ok"], counts["failed"], progress_stream
            )
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
    finally:
        # Closing after a lost scheduler makes Dask log its reconnect's cancellation as an
        # error with a traceback; what matters was said above, and the store keeps the rest.
        for name in ("distributed", "distributed.client"):  # Dask sets both levels
            logging.getLogger(name).setLevel(logging.CRITICAL)
        with contextlib.suppress(Exception):
            client.close(timeout=10)
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close(timeout=20)
    return SweepOutcome(
        counts, ran, interrupted, lost, startup_s, run_phase_s, store_file, first_result_s
    )
