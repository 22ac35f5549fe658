"""Tests of rpod.scenarios.report's grid maps (the 2-parameter campaign figures)."""

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
        {"case_name": "", "grid_point": {"a.x": x, "b.y": y}, "status": "ok", "summary": {}}
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
    assert [p.name for p in large] == ["map_success_rate.png"] == [p.name for p in small]
    large_width, large_height = _png_size(large[0])
    small_width, _ = _png_size(small[0])
    assert large_width < 2500 and large_height < 1500
    assert small_width < large_width
