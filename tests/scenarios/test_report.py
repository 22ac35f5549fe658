"""Tests of rpod.scenarios.report: the mission-success lead and the grid maps."""

import struct

from rpod.scenarios import report


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
