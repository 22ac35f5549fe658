"""Tests of rpod.scenarios.report: the mission-success lead, the grid maps, and the output
folder it may write into."""

import json
import pathlib
import struct

import pytest
from campaign_helpers import run_rpod_in_process as run_rpod

from rpod.scenarios import report
from rpod.scenarios.campaign import PlannedRun
from rpod.scenarios.loader import ScenarioFileError
from rpod.scenarios.store import STORE_NAME, ResultStore


def _png_size(path) -> tuple[int, int]:
    """(width, height) in pixels from the PNG's IHDR chunk."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def _grid(nx, ny):
    x_values = [round(0.1 * i, 3) for i in range(nx)]
    y_values = [round(0.03 * (j + 1), 3) for j in range(ny)]
    meta = {"grid": {"a.x": x_values, "b.y": y_values}}
    rows = [
        {
            "case_name": "",
            "grid_point": {"a.x": x, "b.y": y},
            "status": "ok",
            "metrics": {"mission": {"success": x < 0.2}},
        }
        for x in x_values
        for y in y_values
    ]
    return meta, rows


def test_a_large_grid_is_drawn_in_a_fixed_size_and_a_small_one_cell_by_cell(tmp_path):
    """Paper 003's Case Study 1 grid (79 x 34) would make a 104 x 29 inch figure with one label
    per cell; it is drawn at a fixed size instead, with thinned ticks."""
    (tmp_path / "large").mkdir()
    (tmp_path / "small").mkdir()
    large = report._grid_maps(*_grid(79, 34), [], tmp_path / "large")
    small = report._grid_maps(*_grid(4, 3), [], tmp_path / "small")
    assert [p.name for p in large] == ["map_mission_success.png"] == [p.name for p in small]
    large_width, large_height = _png_size(large[0])
    small_width, _ = _png_size(small[0])
    assert large_width < 2500 and large_height < 1500
    assert small_width < large_width


def _row(grp, status="ok", success=None, contact=False, controller_success=None):
    metrics = None
    if status == "ok":
        mission = {"success": success, "controller_success": controller_success}
        metrics = {"mission": mission, "contact": {"occurred": contact}, "final_range_m": 1.0}
    return {"grp": grp, "status": status, "metrics": metrics, "reason": "boom"}


def test_the_report_leads_with_mission_success_and_its_interval_then_safety():
    """The 'planned and flown without contact' share hid missed goals: the report's first
    figure is the mission success share (Wilson 95 %), over every finished run with a verdict
    (a failed simulation is a failure), then the runs with contact, then the rest."""
    rows = (
        [_row("a", success=True)] * 7
        + [_row("a", success=False)] * 2
        + [_row("a", status="failed")]
        + [_row("b", success=False, contact=True, controller_success=True)]
        + [_row("b", success=None)]
        + [_row("b", status="pending")]
    )
    text = report.summary_text({"campaign_name": "c", "base_name": "x"}, rows, ["final_range_m"])
    lines = text.splitlines()
    assert lines[2] == "Mission success: 63.6 % (7/11; 95 % CI 35.4-84.8 %)"
    assert lines[3] == (
        "Safety: contact of the true shapes in 1 (8.3 %) of 12 finished runs; "
        "1 of them the controller counted a success"
    )
    assert "1 finished runs have no mission to judge" in lines[4]
    group_a = next(line for line in lines if line.startswith("a "))
    assert "70.0 % (7/10; 95 % CI" in group_a and group_a.split()[-2:] == ["1", "0"]
    group_b = next(line for line in lines if line.startswith("b "))
    assert "0.0 % (0/1;" in group_b and "1 (50.0 %)" in group_b
    assert text.index("Mission success") < text.index("Metrics over") < text.index("Simulation")


def test_mission_success_of_each_kind_of_row():
    assert report.mission_success(_row("a", success=True)) is True
    assert report.mission_success(_row("a", status="failed")) is False
    assert report.mission_success(_row("a", status="pending")) is None
    assert report.mission_success(_row("a", success=None)) is None
    old = {"grp": "a", "status": "ok", "metrics": {"final_range_m": 1.0}}  # before verdicts
    assert report.mission_success(old) is None


# ------------------------------------------------------------------------------ the output folder
# `rpod report --out DIR` writes only into a folder it made (or an empty one, or one it wrote
# before), as `rpod run` does; any other existing folder needs --overwrite, and even then only
# the report's own file names are replaced.


def _store(folder: pathlib.Path, count: int = 6) -> pathlib.Path:
    """A results store of `count` finished fake runs in folder."""
    folder.mkdir(parents=True, exist_ok=True)
    runs = [
        PlannedRun(f"{i:016x}", i, f"g{i % 2}", "", {"x": i}, None, {"chaser.mass_kg": 300.0 + i})
        for i in range(count)
    ]
    with ResultStore(folder / STORE_NAME) as store:
        store.write_plan({"campaign_name": "fake", "base_name": "coast", "grid": {}}, runs)
        for i, run in enumerate(runs):
            store.record(
                run.run_id,
                {"status": "ok", "metrics": {"final_range_m": float(i)}, "wall_time_s": 0.1},
            )
    return folder


def _files(folder: pathlib.Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def test_a_new_folder_gets_the_report_and_its_manifest(tmp_path):
    results = _store(tmp_path / "results")
    _, plots = report.write_report(results)
    out = results / "report"
    assert (out / "report.md").is_file() and plots and all(p.parent == out for p in plots)
    manifest = json.loads((out / ".rpod-output").read_text())
    assert manifest["written_by"] == "rpod" and manifest["command"] == "report"
    assert set(manifest["entries"]) == {"report.md", "report.html", *(p.name for p in plots)}


def test_a_report_is_written_again_into_its_own_folder(tmp_path):
    results = _store(tmp_path / "results")
    report.write_report(results, out_dir=tmp_path / "plots")
    report.write_report(results, out_dir=tmp_path / "plots")  # no --overwrite needed
    (tmp_path / "empty").mkdir()
    report.write_report(results, out_dir=tmp_path / "empty")


def test_a_report_folder_from_before_the_manifest_is_the_reports(tmp_path):
    results = _store(tmp_path / "results")
    old = tmp_path / "old"
    old.mkdir()
    (old / "report.md").write_text("an older report\n")
    (old / "hist_final_range_m.png").write_bytes(b"old plot")
    report.write_report(results, out_dir=old)
    assert (old / "report.md").read_text() != "an older report\n"


@pytest.mark.parametrize(
    "contents",
    [
        {"notes.txt": b"mine"},  # somebody's folder
        {"report.md": b"a report", "notes.txt": b"mine"},  # a report, and a file added to it
        {"hist_final_range_m.png": b"my own figure"},  # PNGs but no report: not a report
    ],
    ids=["foreign", "report_plus_a_file", "pngs_only"],
)
def test_a_folder_report_did_not_write_is_refused_and_left_as_it_was(tmp_path, contents):
    results = _store(tmp_path / "results")
    out = tmp_path / "mine"
    out.mkdir()
    for name, data in contents.items():
        (out / name).write_bytes(data)
    with pytest.raises(ScenarioFileError) as error:
        report.write_report(results, out_dir=out)
    message = str(error.value)
    assert message.startswith(f"--out {out}: is a folder that rpod report did not write")
    assert "--overwrite" in message and "\n" not in message
    assert _files(out) == contents  # nothing replaced, nothing added


def test_overwrite_writes_into_a_foreign_folder_and_keeps_it_foreign(tmp_path):
    results = _store(tmp_path / "results")
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / "report.md").write_text("my own report.md")
    report.write_report(results, out_dir=out, overwrite=True)
    assert (out / "notes.txt").read_text() == "mine"  # only the report's names are touched
    assert (out / "report.md").read_text().startswith("```")
    assert "notes.txt" not in json.loads((out / ".rpod-output").read_text())["entries"]
    with pytest.raises(ScenarioFileError, match="did not write"):  # still somebody else's
        report.write_report(results, out_dir=out)


def test_a_report_manifest_of_rpod_run_does_not_make_the_folder_the_reports(tmp_path):
    results = _store(tmp_path / "results")
    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").write_text("{}")
    manifest = {"written_by": "rpod", "format": 1, "entries": ["summary.json"]}
    (out / ".rpod-output").write_text(json.dumps(manifest))
    with pytest.raises(ScenarioFileError, match="did not write"):
        report.write_report(results, out_dir=out)


def test_cli_report_into_a_foreign_folder_exits_2_and_overwrite_writes(tmp_path):
    results = _store(tmp_path / "results")
    out = tmp_path / "mine"
    out.mkdir()
    (out / "report.md").write_text("keep me")
    (out / "notes.txt").write_text("keep me too")
    refused = run_rpod("report", str(results), "--out", str(out), cwd=tmp_path)
    assert refused.returncode == 2, refused.stderr
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"rpod: error: --out {out}: "), lines
    assert (out / "report.md").read_text() == "keep me"
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "report.md"]
    written = run_rpod("report", str(results), "--out", str(out), "--overwrite", cwd=tmp_path)
    assert written.returncode == 0, written.stderr
    assert (out / "notes.txt").read_text() == "keep me too"
    assert (out / "report.md").read_text() != "keep me"


def test_long_names_in_report_errors_are_cut(tmp_path):
    results = _store(tmp_path / "results")
    for out in (tmp_path / ("y" * 4000), tmp_path / ("y" * 4000) / "plots"):
        with pytest.raises(ScenarioFileError) as error:  # a name too long for the file system
            report.write_report(results, out_dir=out)
        assert str(error.value).startswith("--out ") and len(str(error.value)) < 300
    with pytest.raises(ScenarioFileError, match="unknown metric") as error:
        report.write_report(results, metrics=["m" * 4000])
    assert len(str(error.value)) < 500 and "m" * 200 not in str(error.value)
