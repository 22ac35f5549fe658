"""`rpod report RESULTS`: a campaign's results as tables and plots.

Owns: the mission success share of the campaign and of each group (with its Wilson 95 %
interval), which the report leads with, then the safety figures (runs with contact of the true
shapes, successes a controller claimed that contact overturned); for methods flying the same
starts, their comparison (rpod.scenarios.comparison's tables and figures); per-group statistics (count,
metric medians and 5th/95th percentiles), the simulation failures, the tables controller plug-ins add (e.g. soft capture beside paper 000),
and the plots (one histogram per metric, with one series per group; and, for a
campaign with a two-parameter grid, 2-D maps of the success rate and of each metric's median).
Does not own: the store (store.py) or the runs.

A run's mission verdict is its summary's `mission.success`: True or False, and a simulation
that failed is a mission failure; a run with no verdict (no controller, no criterion) is not
counted, and the report says how many there were. Metric statistics are over the runs whose
status is `ok`. A failed run has no trustworthy metrics: a
timeout or crash has none, and a simulation that failed stopped early. A boolean metric
(e.g. `hold_reached`) is reported as the share of runs where it is true. Plots use
matplotlib's object API (Figure, no pyplot), so they are safe in any process.

The output folder (`--out`, default RESULTS/report). A report writes report.md, report.html
(the same as one self-contained page: report_html.py), its plots (.png) and, with `--format
parquet` or `csv`, the table of the runs (tables.py) into the folder, replacing files of the
same names, and last a manifest, `.rpod-output`
(JSON: {"written_by": "rpod", "command": "report", "format": 1, "entries": [...]}, what rpod
report has written there, the format of `rpod run`'s manifest, rpod.scenarios.run). As `rpod
run` does, it writes only where it may replace what is there: a folder that does not exist (it
is made), an empty one, or one rpod report wrote. That is a folder whose report manifest lists
everything in it but report.md and .png files at its top (what a report writes; one stopped
before its manifest leaves some unlisted), or, with no manifest, one holding report.md and
otherwise only .png files (a report from before the manifest). Any other folder is refused,
with one line and exit status 2, unless `overwrite` (`--overwrite`) is given; even then the
report only adds and replaces its own file names and lists only them, so the folder stays
somebody else's. Nothing is ever deleted.
"""

import json
import math
import os
import pathlib
import re

import numpy as np

from rpod.diagrams import controller_seam
from rpod.models.statistics import SuccessShare
from rpod.scenarios.comparison import comparison_figures, comparison_lines
from rpod.scenarios.loader import ScenarioFileError
from rpod.scenarios.store import (
    ResultStore,
    contact_occurred,
    make_folder,
    mission_success,
    store_path,
)

MAX_GROUPS_PER_HISTOGRAM = 8
MANIFEST = ".rpod-output"  # the name of `rpod run`'s manifest (rpod.scenarios.run.MANIFEST)
MANIFEST_FORMAT = 1
REPORT_TEXT = "report.md"
REPORT_HTML = "report.html"  # the same report as one self-contained page (report_html.py)
SHOWN_NAMES = 3  # names of foreign files said in a refusal


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def metric_names(rows: list[dict]) -> list[str]:
    """Scalar metrics (numbers and booleans) of the ok runs, in order of first appearance."""
    names = {}
    for row in rows:
        if row["status"] == "ok" and row["metrics"]:
            for key, value in row["metrics"].items():
                if _is_number(value) or isinstance(value, bool):
                    names.setdefault(key, None)
    return list(names)


def _groups(rows: list[dict]) -> dict[str, list[dict]]:
    groups = {}
    for row in rows:
        groups.setdefault(row["grp"], []).append(row)
    return groups


def _values(rows: list[dict], metric: str) -> np.ndarray:
    values = [
        row["metrics"].get(metric) for row in rows if row["status"] == "ok" and row["metrics"]
    ]
    return np.array([float(v) for v in values if _is_number(v) or isinstance(v, bool)])


def _format(value: float) -> str:
    return f"{value:.4g}"


def _text_table(header: list[str], rows: list[list[str]], right: set[int]) -> list[str]:
    widths = [max(len(str(cell)) for cell in column) for column in zip(header, *rows)]

    def line(cells):
        return "  ".join(
            str(c).rjust(w) if i in right else str(c).ljust(w)
            for i, (c, w) in enumerate(zip(cells, widths))
        ).rstrip()

    return [line(header), line(["-" * w for w in widths])] + [line(r) for r in rows]


def mission_share(rows: list[dict]) -> SuccessShare:
    """Mission successes over the runs with a verdict."""
    verdicts = [v for v in map(mission_success, rows) if v is not None]
    return SuccessShare(sum(verdicts), len(verdicts))


def _percent(k: int, n: int) -> str:
    return f"{k} ({100.0 * k / n:.1f} %)" if n else "--"


def summary_text(
    meta: dict,
    rows: list[dict],
    metrics: list[str],
    results_folder: str = "RESULTS",
    table=None,
) -> str:
    """The report's tables as plain text: mission success first, then safety, then, for a
    campaign of methods flying the same starts, their comparison (rpod.scenarios.comparison;
    its rerun commands name results_folder), then the rest.

    `table(header, rows, right) -> lines` draws each table (default: aligned plain text; the
    HTML report passes its own)."""
    _table = table or _text_table
    groups = _groups(rows)
    finished = [r for r in rows if r["status"] != "pending"]
    judged = mission_share(rows).n
    contacts = sum(map(contact_occurred, finished))
    overturned = sum(
        contact_occurred(r)
        and ((r["metrics"] or {}).get("mission") or {}).get("controller_success") is True
        for r in finished
    )
    lines = [
        (
            f"Campaign {meta.get('campaign_name', '?')}: {len(rows)} runs, base "
            f"{meta.get('base_name', '?')}"
        ),
        "",
        f"Mission success: {mission_share(rows).percent_text()}",
        (
            f"Safety: contact of the true shapes in {_percent(contacts, len(finished))} of "
            f"{len(finished)} finished runs"
            + (f"; {overturned} of them the controller counted a success" if overturned else "")
        ),
    ]
    unjudged = len(finished) - judged
    if unjudged:
        lines.append(f"({unjudged} finished runs have no mission to judge and are not counted)")
    lines.append("")
    group_rows = []
    for name, members in groups.items():
        statuses = [m["status"] for m in members]
        done = [m for m in members if m["status"] != "pending"]
        group_rows.append(
            [
                name,
                len(members),
                mission_share(members).percent_text(),
                _percent(sum(map(contact_occurred, done)), len(done)),
                statuses.count("failed"),
                statuses.count("pending"),
            ]
        )
    lines += _table(
        ["group", "runs", "mission success", "contact", "sim failed", "pending"],
        group_rows,
        {1, 3, 4, 5},
    )
    lines += comparison_lines(meta, rows, results_folder, _table)

    bools = {m for m in metrics if any(isinstance((r["metrics"] or {}).get(m), bool) for r in rows)}
    metric_rows = []
    for name, members in groups.items():
        for metric in metrics:
            values = _values(members, metric)
            if values.size == 0:
                continue
            if metric in bools:
                metric_rows.append(
                    [name, metric, values.size, f"{100.0 * values.mean():.1f}% true", "", ""]
                )
            else:
                p5, p50, p95 = np.percentile(values, [5, 50, 95])
                metric_rows.append(
                    [name, metric, values.size, _format(p50), _format(p5), _format(p95)]
                )
    if metric_rows:
        lines += ["", "Metrics over the ok runs of each group:", ""]
        lines += _table(["group", "metric", "n", "median", "p5", "p95"], metric_rows, {2, 3, 4, 5})

    # Each controller plug-in may add its own table (e.g. a campaign beside its paper).
    for plugin in controller_seam.controller_plugins():
        plugin_table = plugin.campaign_table(rows)
        if plugin_table is not None:
            title, header, table_rows = plugin_table
            lines += ["", title, ""]
            lines += _table(header, table_rows, set())

    reasons = {}
    for row in rows:
        if row["status"] == "failed":
            reason = (row["reason"] or "(no reason)")[:100]
            reasons[reason] = reasons.get(reason, 0) + 1
    if reasons:
        lines += ["", "Simulation failures:", ""]
        lines += _table(
            ["runs", "reason"],
            [[n, r] for r, n in sorted(reasons.items(), key=lambda item: -item[1])],
            {0},
        )
    return "\n".join(lines)


def _safe_name(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "all"


def _save(figure, path: pathlib.Path) -> pathlib.Path:
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    return path


def _histograms(rows, metrics, out_dir: pathlib.Path) -> list[pathlib.Path]:
    from matplotlib.figure import Figure

    groups = _groups(rows)
    series = groups if len(groups) <= MAX_GROUPS_PER_HISTOGRAM else {"all runs": rows}
    paths = []
    for metric in metrics:
        data = {name: _values(members, metric) for name, members in series.items()}
        data = {name: values for name, values in data.items() if values.size}
        if not data:
            continue
        everything = np.concatenate(list(data.values()))
        low, high = float(everything.min()), float(everything.max())
        if high <= low:
            low, high = low - 0.5 * max(abs(low), 1.0), high + 0.5 * max(abs(high), 1.0)
        bins = np.linspace(low, high, 21)
        figure = Figure(figsize=(7, 4))
        axes = figure.add_subplot()
        for name, values in data.items():
            axes.hist(
                values, bins=bins, histtype="step", linewidth=1.5, label=f"{name} ({values.size})"
            )
        axes.set_xlabel(metric)
        axes.set_ylabel("runs")
        axes.set_title(f"{metric}: ok runs")
        if len(data) > 1:
            axes.legend(fontsize=7)
        paths.append(_save(figure, out_dir / f"hist_{_safe_name(metric)}.png"))
    return paths


_ANNOTATED_CELLS = 20
"""Grid maps write each cell's value while both axes have at most this many points; larger
grids are drawn in colour only, in a fixed size, with a tick every few points."""


def _grid_maps(meta, rows, metrics, out_dir: pathlib.Path) -> list[pathlib.Path]:
    """For a 2-parameter grid: success rate and median of each metric per grid point."""
    from matplotlib.figure import Figure

    grid = meta.get("grid") or {}
    if len(grid) != 2:
        return []
    (x_path, x_values), (y_path, y_values) = grid.items()
    paths = []
    for case in sorted({row["case_name"] for row in rows}):
        members = [row for row in rows if row["case_name"] == case]
        cells = {}
        for row in members:
            point = row["grid_point"]
            key = (x_values.index(point[x_path]), y_values.index(point[y_path]))
            cells.setdefault(key, []).append(row)
        maps = {"mission_success": lambda rs: mission_share(rs).share}
        for metric in metrics:
            maps[metric] = lambda rs, m=metric: (
                float(np.median(v)) if (v := _values(rs, m)).size else np.nan
            )
        for name, statistic in maps.items():
            image = np.full((len(y_values), len(x_values)), np.nan)
            for (i, j), rs in cells.items():
                image[j, i] = statistic(rs)
            if np.all(np.isnan(image)):
                continue
            annotated = len(x_values) <= _ANNOTATED_CELLS and len(y_values) <= _ANNOTATED_CELLS
            if annotated:  # one readable number per cell
                size = (1.6 + 1.3 * len(x_values), 1.4 + 0.8 * len(y_values))
            else:  # a large grid (paper 003's 79 x 34): colours only, a tick every few cells
                size = (12.0, 7.0)
            figure = Figure(figsize=size)
            axes = figure.add_subplot()
            mesh = axes.imshow(image, origin="lower", aspect="auto", cmap="viridis")
            for (j, i), value in np.ndenumerate(image if annotated else np.empty((0, 0))):
                if np.isfinite(value):
                    axes.text(
                        i,
                        j,
                        _format(value),
                        ha="center",
                        va="center",
                        fontsize=8,
                        color="white" if value < np.nanmean(image) else "black",
                    )
            x_ticks = range(0, len(x_values), max(1, math.ceil(len(x_values) / _ANNOTATED_CELLS)))
            y_ticks = range(0, len(y_values), max(1, math.ceil(len(y_values) / _ANNOTATED_CELLS)))
            axes.set_xticks(x_ticks, [str(x_values[i]) for i in x_ticks], fontsize=8)
            axes.set_yticks(y_ticks, [str(y_values[i]) for i in y_ticks], fontsize=8)
            axes.set_xlabel(x_path)
            axes.set_ylabel(y_path)
            label = "mission success share" if name == "mission_success" else f"median {name}"
            axes.set_title(f"{label}" + (f" ({case})" if case else ""), fontsize=10)
            figure.colorbar(mesh, ax=axes)
            stem = f"map_{_safe_name(name)}" + (f"_{_safe_name(case)}" if case else "")
            paths.append(_save(figure, out_dir / f"{stem}.png"))
    return paths


def read_results(results) -> tuple[dict, list[dict]]:
    """(meta, rows) of a store, read-only; read again through the WAL if a sweep wrote meanwhile."""
    with ResultStore.open_existing(results) as store:
        meta, rows = store.meta(), store.rows()
        if not store.changed():
            return meta, rows
    with ResultStore.open_existing(results, use_wal=True) as store:
        return store.meta(), store.rows()


def _cut(text, limit: int = 200) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _read_manifest(folder: pathlib.Path) -> set[str] | None:
    """The entries of a report manifest in folder, or None (absent, not one, unreadable)."""
    path = folder / MANIFEST
    try:
        if not path.is_file() or path.is_symlink() or path.stat().st_size > 10_000_000:
            return None
        manifest = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not (
        isinstance(manifest, dict)
        and manifest.get("written_by") == "rpod"
        and manifest.get("command") == "report"
        and isinstance(manifest.get("entries"), list)
    ):
        return None
    return {entry for entry in manifest["entries"] if isinstance(entry, str)}


def _entries(folder: pathlib.Path) -> list[str]:
    """Every file and folder under folder, relative and "/"-separated (links not followed)."""

    def raise_error(error):
        raise error

    entries = []
    for root, dirs, files in os.walk(folder, onerror=raise_error):
        relative = pathlib.Path(root).relative_to(folder)
        entries += [(relative / name).as_posix() for name in sorted(dirs) + sorted(files)]
    return entries


def _a_report_file(entry: str, folder: pathlib.Path) -> bool:
    """report.md or a .png file at the folder's top: what a report writes."""
    path = folder / entry
    return (
        "/" not in entry
        and (entry == REPORT_TEXT or entry.endswith(".png"))
        and path.is_file()
        and not path.is_symlink()
    )


def check_report_folder(out_dir: pathlib.Path, overwrite: bool = False) -> set[str]:
    """The entries rpod report has written in out_dir (module docstring, "The output folder"),
    empty for a new or empty folder; ScenarioFileError (one line naming --out) for a folder rpod
    report did not write, unless `overwrite`. What is not a folder is left to make_folder."""
    label = f"--out {_cut(out_dir)}"
    try:
        if not out_dir.is_dir():
            return set()  # nothing there (made later), or not a folder (make_folder says so)
    except OSError as error:  # e.g. a name too long
        raise ScenarioFileError(f"{label}: cannot be used: {error.strerror}") from None
    listed = _read_manifest(out_dir)
    try:
        entries = _entries(out_dir)
    except OSError as error:
        raise ScenarioFileError(f"{label}: cannot be read: {error.strerror or error}") from None
    if listed is None and REPORT_TEXT not in entries and entries:
        foreign = entries  # no manifest and no report.md: not a report folder
    else:
        foreign = [
            entry
            for entry in entries
            if entry != MANIFEST
            and entry not in (listed or set())
            and not _a_report_file(entry, out_dir)
        ]
    if not foreign:
        return (listed or set()) | {e for e in entries if _a_report_file(e, out_dir)}
    if overwrite:
        return listed or set()
    names = ", ".join(_cut(repr(name), 60) for name in foreign[:SHOWN_NAMES])
    more = ", ..." if len(foreign) > SHOWN_NAMES else ""
    raise ScenarioFileError(
        f"{label}: is a folder that rpod report did not write (it holds {names}{more}); a "
        f"report replaces its files of the same names, so choose another --out, or pass "
        f"--overwrite to write the report into this folder"
    )


def _write_manifest(out_dir: pathlib.Path, entries: set[str]) -> None:
    manifest = {
        "written_by": "rpod",
        "command": "report",
        "format": MANIFEST_FORMAT,
        "entries": sorted(entries),
    }
    staging = out_dir / f"{MANIFEST}.partial-{os.getpid()}"
    staging.write_text(json.dumps(manifest, indent=1) + "\n")
    os.replace(staging, out_dir / MANIFEST)


def write_report(
    results,
    out_dir=None,
    metrics: list[str] | None = None,
    overwrite: bool = False,
    formats: tuple[str, ...] = (),
):
    """(summary text, plot paths); writes report.md, report.html, the plots and the run tables
    of `formats` into out_dir.

    The store is only read (see store.py); a bad --out, one that cannot be written, or an
    existing folder rpod report did not write (unless `overwrite`; module docstring) is a
    ScenarioFileError, raised before anything is written.

    Args:
        results: a campaign output folder or its results.sqlite.
        out_dir: where to write (default: <results folder>/report).
        metrics: metrics to summarise (default: every scalar metric of the ok runs).
        overwrite: write into an existing folder that rpod report did not write (`--overwrite`),
            replacing its files of the same names.
        formats: run tables to write besides the report (rpod.scenarios.tables):
            'parquet' (runs.parquet), 'csv' (runs.csv and its metadata).
    """
    from rpod.scenarios import report_html, tables

    unknown_formats = [f for f in formats if f not in tables.TABLE_FORMATS]
    if unknown_formats:
        raise ScenarioFileError(
            f"--format: unknown format(s) {_cut(', '.join(unknown_formats), 120)} "
            f"(known: {', '.join(tables.TABLE_FORMATS)})"
        )
    meta, rows = read_results(results)
    names = metric_names(rows)
    if metrics:
        unknown = [m for m in metrics if m not in names]
        if unknown:
            raise ScenarioFileError(
                f"{_cut(results)}: --metrics: unknown metric(s) {_cut(', '.join(unknown), 120)} "
                f"(known: {_cut(', '.join(names), 300) or 'none: no run finished ok'})"
            )
        names = metrics
    out_dir = pathlib.Path(out_dir) if out_dir else store_path(results).parent / "report"
    written = check_report_folder(out_dir, overwrite)
    make_folder(out_dir)
    folder = str(store_path(results).parent)
    text = summary_text(meta, rows, names, folder)
    try:
        (out_dir / REPORT_TEXT).write_text("```\n" + text + "\n```\n")
        plots = comparison_figures(rows, out_dir)
        plots += _histograms(rows, names, out_dir) + _grid_maps(meta, rows, names, out_dir)
        for plugin in controller_seam.controller_plugins():  # e.g. a paper's figures
            plots += plugin.campaign_figures(rows, out_dir)
        html_text = summary_text(meta, rows, names, folder, table=report_html.html_table)
        page = report_html.report_html(meta, rows, html_text, folder, plots)
        (out_dir / REPORT_HTML).write_text(page, encoding="utf-8")
        table_files = []
        for fmt in formats:
            table_files += tables.write_table(meta, rows, out_dir, fmt)
        written |= {REPORT_TEXT, REPORT_HTML} | {pathlib.Path(p).name for p in plots + table_files}
        _write_manifest(out_dir, {e for e in written if os.path.lexists(out_dir / e)})
    except OSError as error:
        raise ScenarioFileError(
            f"--out {_cut(out_dir)}: cannot write the report: {_cut(error.strerror or error)}"
        ) from None
    return text, plots
