"""Cost of the campaign engine: per-run overhead, and the speed-up from 1 to 2 workers.

    python benchmarks/bench_campaign.py [--runs N] [--heavy N] [--repeat N]

Prints two tables and writes them to benchmarks/results/campaign.md. Every figure is measured in
this run, and ratios are to references measured in the same run:
- Per-run cost of a near-empty run (`coast` for 1 s, `--runs` of them), and what the engine adds
  to it. The reference is the same runs simulated in one process by a plain loop. The engine's
  figure is its steady state, (last result - first result) / (runs - 1), measured with 1 worker
  so that runs do not overlap. So the one-off costs stay out of it: starting the cluster, and
  the runner's pydrake import before the first result. These are listed apart. Measured with a
  LocalCluster, and through a Dask scheduler and worker started as separate processes on
  127.0.0.1.
- Speed-up from 1 to 2 workers on `--heavy` runs of ~0.5 s (hold_point for 20 s), over the
  whole run phase (from the first submission to the last result, runner start included). The
  reference is the same runs in a plain multiprocessing pool of 1 and 2 processes, already
  warm. That pool's speed-up is what this machine allows at the time.
"""

import argparse
import contextlib
import io
import json
import logging
import multiprocessing
import os
import pathlib
import platform
import shutil
import subprocess
import sys
import tempfile
import time

RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "campaign.md"

NEAR_EMPTY = """\
base: coast
overrides: {{duration_s: 1.0, log_period_s: 1.0}}
sample:
  count: {count}
  seed: 1
  fields: {{chaser.mass_kg: {{dist: uniform, low: 400.0, high: 600.0}}}}
"""

HEAVY = """\
base: hold_point
overrides: {{duration_s: 20.0, log_period_s: 1.0}}
sample:
  count: {count}
  seed: 1
  fields:
    chaser.p_LC_L[1]: {{dist: uniform, low: -35.0, high: -25.0}}
"""


def plan(folder: pathlib.Path, name: str, text: str):
    from rpod.scenarios.campaign import load_campaign, plan_runs

    path = folder / f"{name}.yaml"
    path.write_text(text)
    campaign = load_campaign(str(path))
    return campaign, plan_runs(campaign)


def direct_seconds(campaign, runs) -> float:
    """The reference: the same runs simulated one after the other in this process."""
    from rpod.diagrams.simulate import simulate
    from rpod.scenarios.campaign import apply_overrides

    simulate(apply_overrides(campaign.base, runs[0].overrides))  # warm caches
    start = time.perf_counter()
    for run in runs:
        simulate(apply_overrides(campaign.base, run.overrides))
    return time.perf_counter() - start


def engine(campaign, runs, folder: pathlib.Path, **options):
    """The SweepOutcome of one run_campaign call into a fresh folder."""
    from rpod.scenarios.sweep import run_campaign

    out = folder / f"out-{time.monotonic_ns()}"
    outcome = run_campaign(campaign, runs, out, progress_stream=io.StringIO(), **options)
    assert outcome.counts["ok"] == len(runs), outcome.counts
    shutil.rmtree(out)
    return outcome


@contextlib.contextmanager
def dask_cluster(folder: pathlib.Path, workers: int):
    """A scheduler and `workers` workers as separate processes on 127.0.0.1."""

    processes = []
    scheduler_file = folder / f"scheduler-{time.monotonic_ns()}.json"
    with open(folder / "cluster.log", "a") as log:  # the processes write it until the end
        yield from _cluster_processes(folder, workers, scheduler_file, log, processes)


def _cluster_processes(folder, workers, scheduler_file, log, processes):
    """The body of dask_cluster: starts the processes, yields the address, kills them."""
    from distributed import Client

    try:
        processes.append(
            subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "distributed.cli.dask_scheduler",
                    "--host",
                    "127.0.0.1",
                    "--port",
                    "0",
                    "--no-dashboard",
                    "--scheduler-file",
                    str(scheduler_file),
                ],
                start_new_session=True,
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        )
        deadline = time.monotonic() + 60
        while not (scheduler_file.is_file() and scheduler_file.stat().st_size):
            if time.monotonic() > deadline:
                raise RuntimeError("the scheduler did not start")
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        for _ in range(workers):
            processes.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        "-m",
                        "distributed.cli.dask_worker",
                        address,
                        "--nthreads",
                        "1",
                        "--nworkers",
                        "1",
                        "--no-dashboard",
                        "--host",
                        "127.0.0.1",
                    ],
                    start_new_session=True,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                )
            )
        with Client(address, timeout=30) as client:
            client.wait_for_workers(workers, timeout=60)
        yield address
    finally:
        for process in processes:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, 9)
            process.wait(timeout=10)
        log.close()


def _pool_init():
    logging.getLogger("drake").setLevel(logging.WARNING)
    import rpod.diagrams.builder  # noqa: F401


def _pool_run(scenario):
    from rpod.diagrams.simulate import simulate

    return simulate(scenario).summary["status"]


def pool_seconds(campaign, runs, processes: int) -> float:
    """The reference for speed-up: a warm multiprocessing pool running the same scenarios."""
    from rpod.scenarios.campaign import apply_overrides

    scenarios = [apply_overrides(campaign.base, run.overrides) for run in runs]
    with multiprocessing.get_context("spawn").Pool(processes, initializer=_pool_init) as pool:
        pool.map(_pool_run, scenarios[:processes], chunksize=1)  # warm every process
        start = time.perf_counter()
        statuses = pool.map(_pool_run, scenarios, chunksize=1)
        elapsed = time.perf_counter() - start
    assert all(s == "ok" for s in statuses)
    return elapsed


def steady_state(outcome, runs: int) -> float:
    """Seconds per run between the first and the last result."""
    return (outcome.run_phase_s - outcome.first_result_s) / (runs - 1)


def overhead_table(folder: pathlib.Path, count: int, repeat: int) -> list[str]:
    campaign, runs = plan(folder, "near_empty", NEAR_EMPTY.format(count=count))
    reference = min(direct_seconds(campaign, runs) for _ in range(repeat)) / count
    rows = [("in-process loop of simulate() (reference)", reference, None)]
    local = [engine(campaign, runs, folder, workers=1) for _ in range(repeat)]
    best = min(local, key=lambda outcome: steady_state(outcome, count))
    rows.append(("engine, LocalCluster, 1 worker", steady_state(best, count), best))
    with dask_cluster(folder, 1) as address:
        remote = [engine(campaign, runs, folder, scheduler=address) for _ in range(repeat)]
    best = min(remote, key=lambda outcome: steady_state(outcome, count))
    rows.append(
        ("engine, Dask scheduler + 1 worker (separate processes)", steady_state(best, count), best)
    )
    lines = [
        f"## Per-run cost of a near-empty run (coast, 1 s simulated; {count} runs, 1 worker)",
        "",
        (
            "| how | ms per run | engine overhead (ms per run) | ratio to reference "
            "| cluster start (s) | first result (s) |"
        ),
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name, per_run, outcome in rows:
        cells = [name, f"{1e3 * per_run:.1f}"]
        cells.append("--" if outcome is None else f"{1e3 * (per_run - reference):.1f}")
        cells.append(f"{per_run / reference:.2f}")
        if outcome is None:
            cells += ["--", "--"]
        else:
            cells += [f"{outcome.startup_s:.2f}", f"{outcome.first_result_s:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def speedup_table(folder: pathlib.Path, heavy: int, repeat: int) -> list[str]:
    campaign, runs = plan(folder, "heavy", HEAVY.format(count=heavy))

    def best(measure):
        return min(measure() for _ in range(repeat))

    rows = [
        (
            "multiprocessing pool, warm (reference)",
            best(lambda: pool_seconds(campaign, runs, 1)),
            best(lambda: pool_seconds(campaign, runs, 2)),
        )
    ]
    rows.append(
        (
            "engine, LocalCluster (run phase, each runner's start included)",
            best(lambda: engine(campaign, runs, folder, workers=1).run_phase_s),
            best(lambda: engine(campaign, runs, folder, workers=2).run_phase_s),
        )
    )
    with dask_cluster(folder, 1) as address:
        one = best(lambda: engine(campaign, runs, folder, scheduler=address).run_phase_s)
    with dask_cluster(folder, 2) as address:
        two = best(lambda: engine(campaign, runs, folder, scheduler=address).run_phase_s)
    rows.append(
        (
            (
                "engine, Dask scheduler + workers (separate processes; runners warm after "
                "the first repeat)"
            ),
            one,
            two,
        )
    )
    reference_speedup = rows[0][1] / rows[0][2]
    lines = [
        f"## Speed-up from 1 to 2 workers ({heavy} runs of hold_point, 20 s simulated)",
        "",
        "| how | 1 worker (s) | 2 workers (s) | speed-up | share of the reference speed-up |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for name, one, two in rows:
        lines.append(
            f"| {name} | {one:.2f} | {two:.2f} | {one / two:.2f} | "
            f"{(one / two) / reference_speedup:.2f} |"
        )
    return lines


def main():
    logging.getLogger("drake").setLevel(logging.WARNING)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200, help="runs of the near-empty campaign")
    parser.add_argument("--heavy", type=int, default=16, help="runs of the speed-up campaign")
    parser.add_argument("--repeat", type=int, default=2, help="measurements per case (best kept)")
    args = parser.parse_args()
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as temporary:
        folder = pathlib.Path(temporary)
        overhead = overhead_table(folder, args.runs, args.repeat)
        speedup = speedup_table(folder, args.heavy, args.repeat)
    load_after = os.getloadavg()[0]
    lines = [
        "# Campaign engine benchmark",
        "",
        (
            f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
            f"{platform.python_version()}; 1-minute load average {load_before:.2f} at the start and "
            f"{load_after:.2f} at the end (other processes on the machine share its cores: the "
            f"pool's speed-up below shows what was left); "
            f"`python benchmarks/bench_campaign.py --runs {args.runs} --heavy {args.heavy} "
            f"--repeat {args.repeat}` (best of {args.repeat})."
        ),
        "",
        *overhead,
        "",
        *speedup,
    ]
    text = "\n".join(lines) + "\n"
    print(text)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(text)


if __name__ == "__main__":
    main()
