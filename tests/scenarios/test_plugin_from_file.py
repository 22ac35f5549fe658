"""The README's one-file controller, flown exactly as the README says (issue 20): its files are
taken from README.md, written into a temporary folder, and its four commands run there through
the real command line: `rpod run`, `plan`, `sweep` and `report` with `--plugin`."""

import json
import pathlib
import re
import shlex

import numpy as np
import pytest
from campaign_helpers import run_rpod

README = pathlib.Path(__file__).resolve().parents[2] / "README.md"


def _readme_blocks() -> tuple[dict, list[str]]:
    """({file name: text} of the blocks after `<!-- example: NAME -->`, the commands of the
    block after `<!-- example-commands -->`)."""
    text = README.read_text()
    files = {
        name: body
        for name, body in re.findall(r"<!-- example: (\S+) -->\n```\w*\n(.*?)```", text, re.DOTALL)
    }
    commands = re.search(r"<!-- example-commands -->\n```\w*\n(.*?)```", text, re.DOTALL)
    assert commands, "README.md has no <!-- example-commands --> block"
    lines = [line.strip() for line in commands.group(1).splitlines() if line.strip()]
    return files, lines


@pytest.fixture(scope="module")
def flown(tmp_path_factory) -> tuple[pathlib.Path, list]:
    """The README's files in a fresh folder and the result of each of its commands."""
    folder = tmp_path_factory.mktemp("plugin")
    files, commands = _readme_blocks()
    for name, body in files.items():
        (folder / name).write_text(body)
    results = []
    for line in commands:
        args = shlex.split(line)
        assert args[0] == "rpod"
        results.append(run_rpod(*args[1:], cwd=folder))
    return folder, results


def test_the_readme_gives_a_short_plugin_a_scenario_a_campaign_and_four_commands():
    files, commands = _readme_blocks()
    assert set(files) == {"point_hold.py", "point_hold.yaml", "point_hold_sweep.yaml"}
    assert len(files["point_hold.py"].splitlines()) < 150
    assert [c.split()[1] for c in commands] == ["run", "plan", "sweep", "report"]
    assert all("--plugin point_hold.py" in c for c in commands)


def test_run_flies_the_plugin_and_writes_its_figure(flown):
    folder, results = flown
    run = results[0]
    assert run.returncode == 0, run.stderr
    summary = json.loads((folder / "runs/point_hold/summary.json").read_text())
    assert summary["mission"]["success"] is True
    assert summary["final_goal_error_m"] < 0.5
    assert "point_hold.png" in summary["plots"]
    log = np.load(folder / "runs/point_hold/log.npz")
    assert log["point_hold_error_m"].shape == log["t"].shape
    assert (folder / "runs/point_hold/plots/point_hold.png").stat().st_size > 5000


def test_plan_writes_the_plugins_plan_through_the_common_writer(flown):
    folder, results = flown
    assert results[1].returncode == 0, results[1].stderr
    out = folder / "runs/point_hold-plan"
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["status"], summary["passed"]) == ("success", True)
    assert summary["length_m"] == pytest.approx(20.0)
    assert np.load(out / "plan.npz")["p_L"].shape == (21, 3)
    assert (out / "plots/plan_path.png").stat().st_size > 5000


def test_sweep_and_report_use_the_plugin_in_the_workers_and_its_table(flown):
    sweep, report = flown[1][2], flown[1][3]
    assert sweep.returncode == 0, sweep.stderr
    assert report.returncode == 0, report.stderr
    assert "Point hold over the campaign:" in report.stdout
    assert re.search(r"\b2\b.*\b0\.\d{3}\b", report.stdout.split("Point hold over")[1])
