"""How the suite is shared between pytest-xdist's workers (pyproject: `-n 2 --dist loadgroup`).

Each test file is one group, so its module fixtures run once; files that read the same
session fixture (a campaign swept once, a plan made once) are one group, so that fixture is
made on one worker only, not on each.
"""

import collections

import pytest

SHARED_SESSION_FIXTURES = {
    "campaigns": {"small_campaign_local", "sweep_killed_mid_campaign"},  # scenarios/conftest.py
    "sec_v_a": {"sec_v_a"},  # planners/conftest.py
}


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook reads the marks
def pytest_collection_modifyitems(config, items):
    by_file = collections.defaultdict(list)
    for item in items:
        by_file[item.nodeid.split("::")[0]].append(item)
    for path, file_items in by_file.items():
        used = set().union(*(item.fixturenames for item in file_items))
        group = next(
            (name for name, fixtures in SHARED_SESSION_FIXTURES.items() if fixtures & used), path
        )
        for item in file_items:
            item.add_marker(pytest.mark.xdist_group(group))
