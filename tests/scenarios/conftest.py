"""Fixtures of the campaign tests: processes in their own sessions, killed with their group at
teardown whatever the outcome; a real Dask cluster on 127.0.0.1; the small campaign run once.
Every wait has a bounded timeout.
"""

import subprocess

import pytest
from campaign_helpers import SMALL_CAMPAIGN, DaskCluster, kill_group, run_rpod


@pytest.fixture
def spawn():
    """Starts processes in their own sessions; kills every group at teardown."""
    started = []

    def start(command, **kwargs) -> subprocess.Popen:
        process = subprocess.Popen(command, start_new_session=True, **kwargs)
        started.append(process)
        return process

    yield start
    for process in reversed(started):
        kill_group(process)


@pytest.fixture
def dask_cluster(spawn, tmp_path):
    """start(workers) -> a DaskCluster on 127.0.0.1, torn down with the test."""
    clusters = []

    def start(workers: int = 2) -> DaskCluster:
        folder = tmp_path / f"cluster{len(clusters)}"
        folder.mkdir()
        cluster = DaskCluster(spawn, folder, workers)
        clusters.append(cluster)
        return cluster

    yield start
    for cluster in clusters:
        for handle in cluster.logs:
            handle.close()


@pytest.fixture(scope="session")
def small_campaign_local(tmp_path_factory):
    """The small campaign run locally once through the CLI: (campaign file, output folder)."""
    folder = tmp_path_factory.mktemp("small_local")
    campaign = folder / "small.yaml"
    campaign.write_text(SMALL_CAMPAIGN)
    process = run_rpod(
        "sweep", str(campaign), "--out", str(folder / "out"), "--workers", "2", cwd=folder
    )
    assert process.returncode == 0, process.stderr
    return campaign, folder / "out", process
