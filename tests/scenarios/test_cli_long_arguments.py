"""A command-line argument thousands of characters long is one short error line, exit 2: a
scenario name too long for the file system, a 5,000-digit --seed, a long --rerun id."""

import pytest
from campaign_helpers import run_rpod_in_process as run_rpod


@pytest.mark.parametrize(
    "args",
    [
        ["run", "x" * 4000],
        ["sweep", "demo_sweep", "--seed", "9" * 5000],
        ["sweep", "demo_sweep", "--rerun", "f" * 4000],
    ],
    ids=["scenario_name", "seed", "rerun_id"],
)
def test_a_very_long_argument_is_one_short_line(tmp_path, args):
    process = run_rpod(*args, cwd=tmp_path)
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rpod") and len(lines[0]) < 400, lines
