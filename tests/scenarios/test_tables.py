"""Tests of rpod.scenarios.tables: a campaign's runs as Parquet and CSV, read back by pandas and
by the csv module, each value the store's, with the types and units in the files' metadata."""

import csv
import json

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from campaign_helpers import run_rpod_in_process as run_rpod
from report_store import make_store

from rpod.scenarios import report, tables


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return make_store(tmp_path_factory.mktemp("tables") / "results")


@pytest.mark.parametrize(
    "name, unit",
    [
        ("delta_v_m_s", "m/s"),
        ("capture.time_s", "s"),
        ("set.target.w_IT_T_deg_s", "deg/s"),
        ("set.chaser.mass_kg", "kg"),
        ("final_p_LC_L", "m"),
        ("navigation.v_LC_L", "m/s"),
        ("q_IT", "1"),
        ("hold_point_L", None),
        ("a_max_m_s2", "m/s^2"),
        ("control_step_ms_p99", "ms"),
        ("set.target.inertia_kg_m2", "kg m^2"),
        ("clipped_command_samples", None),
        ("planner_status", None),
    ],
)
def test_units_come_from_the_names(name, unit):
    assert tables.unit_of(name) == unit


def test_parquet_reads_back_in_pandas_with_every_value_and_its_unit(store, tmp_path):
    meta, rows = report.read_results(store)
    (path,) = tables.write_table(meta, rows, tmp_path, "parquet")
    frame = pd.read_parquet(path)
    assert list(frame["run_id"]) == [row["run_id"] for row in rows]  # plan order, every run
    assert list(frame["status"]) == ["ok"] * 5 + ["failed", "pending"]
    # the outcome: True, False, None (no verdict, pending), a failed simulation is False
    assert frame["mission_success"].tolist() == [True, True, True, False, None, False, None]
    assert frame["contact"].tolist() == [False, False, False, True, False, None, None]
    assert frame["mission_outcome"][3] == "NOT captured: position"
    assert frame["reason"][5] == "timeout after 600 s"
    # overrides by their --set path; a vector is an array per cell; a whole config per field
    assert frame["set.chaser.mass_kg"].tolist() == [300.0 + i for i in range(7)]
    tumble = np.linalg.norm(np.stack(frame["set.target.w_IT_T_deg_s"]), axis=1)
    np.testing.assert_array_equal(tumble, 1.0 + np.arange(7))
    assert frame["set.controller.!tag"][0] == "HoldPoint" and pd.isna(
        frame["set.controller.!tag"][1]
    )
    # metrics, nested blocks by dotted names, with their types
    assert frame["delta_v_m_s"][:5].tolist() == [1.5 + 0.1 * i for i in range(5)]
    assert np.isnan(frame["delta_v_m_s"][5])
    assert frame["capture.time_s"][4] == 44.0
    assert frame["clipped_command_samples"].dtype == "float64"  # int64 with nulls: pandas floats
    assert list(frame["final_p_LC_L"][2]) == [2.0, -2.0, 0.25]
    schema = pq.read_schema(path)
    assert str(schema.field("clipped_command_samples").type) == "int64"
    assert str(schema.field("hold_reached").type) == "bool"
    assert schema.field("final_p_LC_L").type.value_type == "double"
    units = {name: (schema.field(name).metadata or {}).get(b"unit") for name in schema.names}
    assert units["delta_v_m_s"] == b"m/s" and units["capture.time_s"] == b"s"
    assert units["set.target.w_IT_T_deg_s"] == b"deg/s" and units["status"] is None
    assert schema.field("mission_success").metadata[b"description"].startswith(b"the mission")
    # what cannot be one column is said, not dropped silently
    left_out = json.loads(schema.metadata[b"rpod.left_out"])
    assert {"plan_records", "solves_by_status"} <= set(left_out)
    assert schema.metadata[b"rpod.campaign"] == b"fake"


def test_the_readme_question_success_against_tumble_rate(store, tmp_path):
    """The README's three lines of pandas, on a known store: the share per tumble bin."""
    meta, rows = report.read_results(store)
    (path,) = tables.write_table(meta, rows, tmp_path, "parquet")
    df = pd.read_parquet(path)
    df["tumble_deg_s"] = df["set.target.w_IT_T_deg_s"].map(np.linalg.norm)
    share = df.groupby(pd.cut(df.tumble_deg_s, [0, 2.5, 8]), observed=True).mission_success.mean()
    assert share.tolist() == [1.0, pytest.approx(1 / 3)]  # 2/2 up to 2.5 deg/s; 1/3 judged above


def test_csv_has_the_same_table_and_its_csvw_metadata(store, tmp_path):
    meta, rows = report.read_results(store)
    path, metadata_path = tables.write_table(meta, rows, tmp_path, "csv")
    columns, types, _ = tables.run_table(rows)
    with open(path, newline="") as file:
        records = list(csv.DictReader(file))
    assert list(records[0]) == list(columns)
    for i, record in enumerate(records):  # every cell reads back to the store's value
        for name, text in record.items():
            value = columns[name][i]
            if value is None:
                assert text == ""
            elif types[name] == "float64":
                assert float(text) == value or (np.isnan(value) and text == "NaN")
            elif types[name] == "list<float64>":
                assert json.loads(text) == value
            elif types[name] == "bool":
                assert text == ("true" if value else "false")
            else:
                assert text == str(value)
    metadata = json.loads(metadata_path.read_text())
    assert metadata["url"] == path.name and metadata["tableSchema"]["primaryKey"] == "run_id"
    described = {c["name"]: c for c in metadata["tableSchema"]["columns"]}
    assert list(described) == list(columns)
    assert described["delta_v_m_s"]["datatype"] == "double"
    assert described["delta_v_m_s"]["schema:unitText"] == "m/s"
    assert described["clipped_command_samples"]["datatype"] == "integer"
    assert described["final_p_LC_L"]["datatype"] == "json"


def test_rpod_report_format_writes_the_tables_and_lists_them(store, tmp_path):
    out = tmp_path / "report"
    done = run_rpod("report", store, "--out", out, "--format", "parquet,csv", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "runs.parquet, runs.csv" in done.stdout
    manifest = json.loads((out / ".rpod-output").read_text())
    assert {"runs.parquet", "runs.csv", "runs.csv-metadata.json", "report.html"} <= set(
        manifest["entries"]
    )
    assert len(pd.read_parquet(out / "runs.parquet")) == 7


def test_an_unknown_format_is_one_line_and_writes_nothing(store, tmp_path):
    out = tmp_path / "report"
    done = run_rpod("report", store, "--out", out, "--format", "xlsx", cwd=tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0 and "--format" in done.stderr
    assert "xlsx" in done.stderr and "parquet" in done.stderr
    assert not out.exists()
