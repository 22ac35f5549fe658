"""Fixtures of the whole suite: work made once per test session and shared by pytest-xdist's
workers (a session fixture is otherwise made once per worker, so an expensive one ran twice)."""

import fcntl
import os
import pathlib
import shutil

import pytest

from rpod.scenarios.entry import BLAS_THREAD_VARIABLES

# One BLAS thread per process, as `rpod` sets it (rpod.scenarios.entry says why): the suite's
# two workers share two cores. Set here, before any test module imports numpy.
for _name in BLAS_THREAD_VARIABLES:
    os.environ.setdefault(_name, "1")


@pytest.fixture(scope="session")
def made_once(tmp_path_factory):
    """made_once(name, make) -> the folder `name`, filled by make(folder) once per session.

    The first worker to ask makes it under a file lock in the session's shared temporary
    folder; the others wait for it and get the same folder. Read it, never change it: copy
    what a test changes. If make raises, nothing is kept and the next worker to ask tries again.
    """
    base = tmp_path_factory.getbasetemp()
    root = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base

    def get(name: str, make) -> pathlib.Path:
        folder, done = root / name, root / f"{name}.done"
        with open(root / f"{name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not done.exists():
                shutil.rmtree(folder, ignore_errors=True)
                folder.mkdir()
                make(folder)
                done.touch()
        return folder

    return get


# The longest test files (seconds of the default run, measured with `pytest --durations=0` on
# 2 cores), handed to the xdist workers first: `--dist loadfile` sends whole files, and by
# default in the order of their test counts, so a 30 s file of one test came last and the
# other worker idled while it ran. Files that start processes (sweeps: a cluster, runners)
# alternate with files that compute in the worker, so that the two workers' first files are
# not both a swarm of processes on two cores. The rest follow in collection order (pyproject's
# addopts turn xdist's own reordering off). An unknown or renamed file only loses its place.
LONGEST_FIRST = (
    "tests/scenarios/test_sweep_local.py",  # 52-58 s, processes
    "tests/planners/test_coupled_casadi.py",  # 35-46 s
    "tests/scenarios/test_sweep_reliability.py",  # 49 s, processes
    "tests/diagrams/controllers/planar_approach/test_planar_approach_plugin.py",  # 44 s
    "tests/scenarios/test_store_readonly.py",  # 25 s, processes
    "tests/scenarios/test_run_los_corridor.py",  # 44 s
    "tests/scenarios/test_sweep_dask_cluster.py",  # 22 s, processes
    "tests/planners/test_planar_approach_planner.py",  # 27 s
    "tests/scenarios/test_plugin_from_file.py",  # 19 s, processes
    "tests/diagrams/test_navigation.py",  # 26 s
    "tests/models/test_relative_navigation.py",  # 22 s
    "tests/scenarios/test_run_soft_capture.py",  # 20 s
    "tests/scenarios/test_los_table3_guard.py",  # 18 s
    "tests/planners/test_soft_capture_rates.py",  # 17 s
)


def pytest_collection_modifyitems(config, items):
    """Puts the tests of LONGEST_FIRST's files first, in its order (a stable sort)."""
    rank = {path: i for i, path in enumerate(LONGEST_FIRST)}
    root = config.rootpath
    items.sort(key=lambda item: rank.get(item.path.relative_to(root).as_posix(), len(rank)))
