"""Fixtures of the whole suite: work made once per test session and shared by pytest-xdist's
workers (a session fixture is otherwise made once per worker, so an expensive one ran twice)."""

import fcntl
import os
import pathlib
import shutil

import pytest


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
