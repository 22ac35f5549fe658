"""A campaign's runs as one table: Parquet and CSV files for pandas and the tools engineers use.

Owns: `run_table` (one row per run: who it is, the mission outcome first, every override, every
scalar metric of its summary), the columns' types, units and descriptions, and writing the
table as `runs.parquet` (pyarrow; the units and descriptions are each field's metadata, the
campaign's name and base the file's) or as `runs.csv` with a W3C CSV-on-the-Web metadata file
beside it (`runs.csv-metadata.json`, https://www.w3.org/TR/tabular-metadata/) that carries the
same types, units and descriptions.
Does not own: the store (store.py), what counts as a mission success (store.mission_success),
or the report's text and figures (report.py).

The columns, in order:
- `run_id`, `group`, `case`, `sample_index`, `status` (`ok`, `failed`, `pending`), `reason`
  (why a simulation failed), `wall_time_s`;
- the outcome: `mission_success` (True, False, or null: no verdict, as the report counts),
  `mission_outcome` (the line `rpod run` prints), `contact` (the true shapes touched);
- `set.<path>`: each override of the run, by its dotted path as `--set` takes it (an override
  that replaces a whole config, as a campaign case does, one column per field:
  `set.controller.!tag`, `set.controller.mpc.horizon`);
- each metric of the run's summary.json, nested blocks flattened with dots
  (`capture.time_s`, `mission.criterion`, `contact.max_depth_m`).

A number is float64 (int64 when every value is an integer), a flag bool, a text string; a
list of numbers (a vector such as `final_p_LC_L` or `set.target.w_IT_T_deg_s`) is a Parquet
list of float64 (in pandas an array per cell: `np.linalg.norm(np.stack(df[col]), axis=1)`) and,
in the CSV, its JSON text. A missing value is null. What cannot be a column of one type
(per-plan records, `warnings`, the per-status counts of a solver) is left in the store, and the
files' metadata says which keys were left out.

Units come from the names (rpod names every quantity with its unit, DESIGN.md "Conventions"):
a suffix (`_m`, `_m_s`, `_s`, `_kg`, `_deg`, `_deg_s`, `_N`, `_ms`, ...), before a statistic's
(`control_step_ms_p99`), or a monogram (`p_LC_L` a position [m], `v_..` a velocity [m/s], `w_..`
a rate [rad/s], `q_..` a unit quaternion [1]).
A column whose name states no unit has none in the metadata (counts, flags, texts).
"""

import csv
import json
import math
import pathlib
import re

from rpod.scenarios.store import contact_occurred, mission_success

TABLE_FORMATS = ("parquet", "csv")
TABLE_NAMES = {"parquet": "runs.parquet", "csv": "runs.csv"}
CSV_METADATA = "runs.csv-metadata.json"
FORMAT_VERSION = "1"

_LEADING = {
    "run_id": ("string", "the run's id in the store (rpod sweep --rerun RUN_ID)"),
    "group": ("string", "the campaign group (case and grid point) of the run"),
    "case": ("string", "the campaign case of the run"),
    "sample_index": ("int64", "the run's sample (start) index, the same start in every case"),
    "status": ("string", "ok, failed (the simulation failed) or pending (not run yet)"),
    "reason": ("string", "why the simulation failed"),
    "wall_time_s": ("float64", "the run's wall time in its runner"),
    "mission_success": ("bool", "the mission verdict; a failed simulation is false; null: none"),
    "mission_outcome": ("string", "the outcome line rpod run prints"),
    "contact": ("bool", "whether the true shapes touched anywhere in the run"),
}

# Unit suffixes, longest first so that `_m_s2` is not read as `_s2`.
_SUFFIX_UNITS = (
    ("_kg_m2", "kg m^2"),
    ("_m_s2", "m/s^2"),
    ("_deg_s", "deg/s"),
    ("_rad_s", "rad/s"),
    ("_m_s", "m/s"),
    ("_N_s", "N s"),
    ("_Nm", "N m"),
    ("_deg", "deg"),
    ("_rad", "rad"),
    ("_kg", "kg"),
    ("_ms", "ms"),
    ("_km", "km"),
    ("_m", "m"),
    ("_s", "s"),
    ("_N", "N"),
)
_MONOGRAM_UNITS = {"p": "m", "v": "m/s", "w": "rad/s", "q": "1"}


_STATISTIC = re.compile(r"_(p\d+|max|min|median|mean|std|rms)$")  # control_step_ms_p99
_MONOGRAM = re.compile(r"(^|_)([pvwq])_[A-Z]{2}(_[A-Z])?$")  # final_p_LC_L, v_LC_L, q_IT


def unit_of(column: str) -> str | None:
    """The unit a column's name states (module docstring), or None when it states none."""
    name = _STATISTIC.sub("", column.rsplit(".", 1)[-1])
    for suffix, unit in _SUFFIX_UNITS:
        if name.endswith(suffix):
            return unit
    monogram = _MONOGRAM.search(name)
    return None if monogram is None else _MONOGRAM_UNITS[monogram.group(2)]


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


_FIELD_NAME = re.compile(r"^!?[A-Za-z_][A-Za-z0-9_]*$")  # a config's or a summary's key


def _flatten(value, prefix: str, out: dict) -> None:
    """Flattens nested dicts into dotted keys; leaves are kept as they are. A dict keyed by
    data rather than by field names (e.g. a count per solver message) is a leaf, so it is
    left out of the table rather than made into a column per message."""
    if isinstance(value, dict) and value and all(_FIELD_NAME.match(str(k)) for k in value):
        for key, item in value.items():
            _flatten(item, f"{prefix}.{key}" if prefix else str(key), out)
    else:
        out[prefix] = value


def _kind(values: list) -> str | None:
    """The column type of a column's values (None values aside), or None if it has none."""
    present = [v for v in values if v is not None]
    if not present:
        return "float64"  # every value missing: a column of nulls
    if all(isinstance(v, bool) for v in present):
        return "bool"
    if all(_is_number(v) for v in present):
        return "int64" if all(isinstance(v, int) for v in present) else "float64"
    if all(isinstance(v, str) for v in present):
        return "string"
    if all(isinstance(v, list) and all(_is_number(x) for x in v) for v in present):
        return "list<float64>"
    return None


def run_table(rows: list[dict]) -> tuple[dict[str, list], dict[str, str], list[str]]:
    """(columns, types, left_out): the store's rows as one table (module docstring).

    columns maps each column's name to its values, one per row, in the store's plan order;
    types maps it to 'string', 'int64', 'float64', 'bool' or 'list<float64>'; left_out names
    the summary keys that are not columns (not of one column type).
    """
    flat_rows = []
    for row in rows:
        metrics = row["metrics"] or {}
        flat = {
            "run_id": row["run_id"],
            "group": row["grp"],
            "case": row["case_name"],
            "sample_index": row["sample_index"],
            "status": row["status"],
            "reason": row["reason"],
            "wall_time_s": row["wall_time_s"],
            "mission_success": mission_success(row),
            "mission_outcome": (metrics.get("mission") or {}).get("outcome"),
            "contact": contact_occurred(row) if row["status"] == "ok" else None,
        }
        for path, value in (row["overrides"] or {}).items():
            _flatten(value, f"set.{path}", flat)  # a whole config: set.controller.!tag, ...
        nested = {}
        _flatten(metrics, "", nested)
        for key, value in nested.items():
            if key not in _LEADING and not key.startswith("set."):
                flat[key] = value
        flat_rows.append(flat)

    names: dict[str, None] = dict.fromkeys(_LEADING)
    for flat in flat_rows:
        names.update(dict.fromkeys(flat))
    columns, types, left_out = {}, {}, []
    for name in names:
        values = [flat.get(name) for flat in flat_rows]
        kind = _LEADING[name][0] if name in _LEADING else _kind(values)
        if kind is None:
            left_out.append(name)
            continue
        if kind == "float64":
            values = [None if v is None else float(v) for v in values]
        elif kind == "list<float64>":
            values = [None if v is None else [float(x) for x in v] for v in values]
        columns[name], types[name] = values, kind
    return columns, types, left_out


def describe(name: str) -> str:
    """A column's description: the leading columns' own, else what its name says it is."""
    if name in _LEADING:
        return _LEADING[name][1]
    if name.startswith("set."):
        return f"the run's override of {name[4:]} (as rpod sweep set it)"
    return f"summary.json's {name}"


def _file_metadata(meta: dict, left_out: list[str]) -> dict[str, str]:
    return {
        "rpod.table_format": FORMAT_VERSION,
        "rpod.campaign": str(meta.get("campaign_name", "")),
        "rpod.base": str(meta.get("base_name", "")),
        "rpod.left_out": json.dumps(left_out),
    }


def write_parquet(meta: dict, rows: list[dict], path: pathlib.Path) -> pathlib.Path:
    """Writes the run table as Parquet, each field's unit and description in its metadata."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrow_types = {
        "string": pa.string(),
        "int64": pa.int64(),
        "float64": pa.float64(),
        "bool": pa.bool_(),
        "list<float64>": pa.list_(pa.float64()),
    }
    columns, types, left_out = run_table(rows)
    fields, arrays = [], []
    for name, values in columns.items():
        field_metadata = {"description": describe(name)}
        if (unit := unit_of(name)) is not None and types[name] != "bool":
            field_metadata["unit"] = unit
        field = pa.field(name, arrow_types[types[name]], metadata=field_metadata)
        fields.append(field)
        arrays.append(pa.array(values, type=field.type))
    schema = pa.schema(fields, metadata=_file_metadata(meta, left_out))
    pq.write_table(pa.Table.from_arrays(arrays, schema=schema), path)
    return path


_CSVW_TYPES = {
    "string": "string",
    "int64": "integer",
    "float64": "double",
    "bool": "boolean",
    "list<float64>": "json",
}


def _csv_cell(value, kind: str) -> str:
    if value is None:
        return ""
    if kind == "bool":
        return "true" if value else "false"
    if kind == "list<float64>":
        return json.dumps(value)
    if kind == "float64":  # XML Schema's lexical forms, which CSVW's double takes
        if math.isnan(value):
            return "NaN"
        if math.isinf(value):
            return "INF" if value > 0 else "-INF"
        return repr(value)
    return str(value)


def write_csv(meta: dict, rows: list[dict], path: pathlib.Path) -> list[pathlib.Path]:
    """Writes the run table as CSV and its CSV-on-the-Web metadata beside it (module docstring).

    A float is written exactly (its shortest round-trip text); a missing value is empty, a vector
    its JSON text, a flag true/false.
    """
    columns, types, left_out = run_table(rows)
    names = list(columns)
    with open(path, "w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(names)
        for i in range(len(rows)):
            writer.writerow(_csv_cell(columns[name][i], types[name]) for name in names)
    described = []
    for name in names:
        column = {"name": name, "titles": name, "datatype": _CSVW_TYPES[types[name]]}
        column["dc:description"] = describe(name)
        if (unit := unit_of(name)) is not None and types[name] != "bool":
            column["schema:unitText"] = unit
        described.append(column)
    metadata = {
        "@context": "http://www.w3.org/ns/csvw",
        "url": path.name,
        "dc:title": f"rpod campaign {meta.get('campaign_name', '?')}: one row per run",
        "dc:source": f"rpod sweep {meta.get('campaign_name', '?')}, base "
        f"{meta.get('base_name', '?')}; table format {FORMAT_VERSION}",
        "rdfs:comment": "summary keys left in the store (not of one column type): "
        + (", ".join(left_out) or "none"),
        "dialect": {"header": True, "encoding": "utf-8"},
        "null": "",
        "tableSchema": {"columns": described, "primaryKey": "run_id"},
    }
    metadata_path = path.with_name(CSV_METADATA)
    metadata_path.write_text(json.dumps(metadata, indent=1) + "\n")
    return [path, metadata_path]


def write_table(meta: dict, rows: list[dict], out_dir: pathlib.Path, fmt: str) -> list:
    """Writes the run table in format fmt ('parquet' or 'csv') into out_dir; the paths written."""
    path = pathlib.Path(out_dir) / TABLE_NAMES[fmt]
    if fmt == "parquet":
        return [write_parquet(meta, rows, path)]
    if fmt == "csv":
        return write_csv(meta, rows, path)
    raise ValueError(f"unknown table format {fmt!r} (known: {', '.join(TABLE_FORMATS)})")
