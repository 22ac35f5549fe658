"""`rpod report`'s `report.html`: the campaign report as one self-contained page.

Owns: turning the report's text (rpod.scenarios.report.summary_text, drawn with HTML tables),
the failed runs with their `rpod sweep --rerun` commands, and the report's figures (embedded as
base64 PNG data) into one HTML file with its style inline: no script, no server, no network, so
it can be mailed to a colleague and opened in any browser.
Does not own: what the report says (report.py, comparison.py) or the figures (drawn there).

The page leads, as the text does, with the campaign's mission success and its safety line,
set large; then the text's tables, the failed runs, and the figures under their file names.
"""

import base64
import html
import pathlib

from rpod.scenarios.store import contact_occurred, mission_success, rerun_command

_TABLE_MARK = "\x00html-table\x00"  # prefixes a line that holds an HTML table, not text
MAX_FAILED_LISTED = 500
_OWN_PARAGRAPH = ("Mission success", "Safety:")

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; color: #222;
       padding: 0 1em; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; }
h2 { font-size: 1.15em; margin-top: 1.8em; border-bottom: 1px solid #ccc; }
p.lead { font-size: 1.4em; margin: 0.4em 0; }
p.safety { font-size: 1.1em; margin: 0.2em 0 1em 0; }
p.alarm { color: #a00; font-weight: 600; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; vertical-align: top; }
th { background: #eef; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr:nth-child(even) td { background: #f8f8f8; }
code { font-size: 0.95em; }
figure { display: inline-block; margin: 0.5em; vertical-align: top; }
figure img { max-width: 560px; border: 1px solid #ddd; }
figcaption { font-size: 0.8em; color: #555; }
"""


def html_table(header: list[str], rows: list[list], right: set[int]) -> list[str]:
    """A table drawn as one marked line of HTML (summary_text's `table` argument)."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = []
    for row in rows:
        cells = []
        for i, cell in enumerate(row):
            text = html.escape(str(cell))
            if text.startswith("rpod "):
                text = f"<code>{text}</code>"
            cells.append(f'<td class="num">{text}</td>' if i in right else f"<td>{text}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return [_TABLE_MARK + f"<table><tr>{head}</tr>{''.join(body)}</table>"]


def _text_to_html(text: str, contact: bool) -> list[str]:
    """The report's text (tables marked by html_table) as HTML blocks.

    The first line is the title, the next paragraph (mission success) the lead, the one after
    it (safety) set below it, in red when a run touched (`contact`); a paragraph that ends
    with ':' and precedes a table heads it.
    """
    blocks, paragraph = [], []

    def flush():
        if paragraph:
            blocks.append(("p", " ".join(paragraph)))
            paragraph.clear()

    for line in text.splitlines():
        if line.startswith(_TABLE_MARK):
            flush()
            blocks.append(("table", line[len(_TABLE_MARK) :]))
        elif not line.strip():
            flush()
        elif line.startswith(_OWN_PARAGRAPH):  # the lead lines stand alone
            flush()
            blocks.append(("p", line.strip()))
        else:
            paragraph.append(line.strip())
    flush()

    out = []
    for index, (kind, content) in enumerate(blocks):
        if kind == "table":
            out.append(content)
            continue
        escaped = html.escape(content)
        heads_a_table = index + 1 < len(blocks) and blocks[index + 1][0] == "table"
        if index == 0:
            out.append(f"<h1>{escaped}</h1>")
        elif content.startswith("Mission success"):
            out.append(f'<p class="lead"><b>{escaped}</b></p>')
        elif content.startswith("Safety:"):
            alarm = " alarm" if contact else ""
            out.append(f'<p class="safety{alarm}">{escaped}</p>')
        elif heads_a_table and content.endswith(":") or content.startswith("Starts on which"):
            out.append(f"<h2>{escaped}</h2>")
        else:
            out.append(f"<p>{escaped}</p>")
    return out


def _failed_runs(meta: dict, rows: list[dict], results_folder: str) -> list[str]:
    """The runs whose mission failed, each with the command that flies it again."""
    failed = [row for row in rows if mission_success(row) is False]
    if not failed:
        return []
    table_rows = []
    for row in failed[:MAX_FAILED_LISTED]:
        mission = (row["metrics"] or {}).get("mission") or {}
        why = row["reason"] if row["status"] == "failed" else mission.get("outcome", "")
        table_rows.append(
            [
                row["run_id"],
                row["grp"],
                "" if row["sample_index"] is None else row["sample_index"],
                why or "",
                rerun_command(meta, results_folder, row["run_id"]),
            ]
        )
    shown = "" if len(failed) <= MAX_FAILED_LISTED else f" (the first {MAX_FAILED_LISTED})"
    lines = [f"<h2>Failed runs: {len(failed)}{html.escape(shown)}</h2>"]
    table = html_table(["run", "group", "start", "why", "fly it again"], table_rows, {2})
    return lines + [table[0][len(_TABLE_MARK) :]]


def _figures(plots: list[pathlib.Path]) -> list[str]:
    if not plots:
        return []
    out = ["<h2>Figures</h2>"]
    for plot in plots:
        data = base64.b64encode(pathlib.Path(plot).read_bytes()).decode("ascii")
        name = html.escape(pathlib.Path(plot).name)
        out.append(
            f'<figure><img alt="{name}" src="data:image/png;base64,{data}">'
            f"<figcaption>{name}</figcaption></figure>"
        )
    return out


def report_html(
    meta: dict, rows: list[dict], text: str, results_folder: str, plots: list[pathlib.Path]
) -> str:
    """The whole page (module docstring); text is summary_text drawn with html_table."""
    title = html.escape(f"rpod report: {meta.get('campaign_name', '?')}")
    contact = any(map(contact_occurred, rows))
    body = _text_to_html(text, contact) + _failed_runs(meta, rows, results_folder) + _figures(plots)
    return (
        "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        f"<title>{title}</title><style>{_STYLE}</style></head><body>\n"
        + "\n".join(body)
        + "\n</body></html>\n"
    )
