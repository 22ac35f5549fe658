"""Tests of rpod.scenarios.report_html: report.html is one self-contained page that leads with
the mission's success, flags contact, lists the failed runs with their rerun commands and
shows the figures, checked in the file and in the pixels headless Chromium draws."""

import re

import numpy as np
import pytest
from matplotlib.image import imread
from report_store import make_store

from rpod.diagrams.recording import find_chromium, screenshot_html
from rpod.scenarios import report
from rpod.scenarios.store import rerun_command


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    results = make_store(tmp_path_factory.mktemp("html") / "results")
    _, plots = report.write_report(results)
    return results, plots, (results / "report" / "report.html")


def test_the_page_holds_everything_itself(written):
    _, plots, page = written
    text = page.read_text(encoding="utf-8")
    assert not re.search(r"<script|<link|<iframe|(src|href)=[\"']?(https?:|//|file:)", text)
    images = re.findall(r'<img alt="([^"]+)" src="data:image/png;base64,', text)
    assert images == [plot.name for plot in plots] and images  # every figure, inline


def test_the_page_leads_with_the_mission_then_safety_and_lists_the_failed_runs(written):
    results, _, page = written
    text = page.read_text(encoding="utf-8")
    lead = text.index('<p class="lead"><b>Mission success: 60.0 % (3/5;')
    safety = text.index('<p class="safety alarm">Safety: contact of the true shapes in 1')
    assert text.index("<h1>Campaign fake: 7 runs") < lead < safety < text.index("<table>")
    failed = text[text.index("<h2>Failed runs: 2</h2>") :]
    for run_id, why in [
        ("0000000000000003", "NOT captured: position"),
        ("0000000000000005", "timeout after 600 s"),
    ]:
        assert f"<td>{run_id}</td>" in failed and why in failed
        assert f"<code>rpod sweep fake --out {results} --rerun {run_id}</code>" in failed
    assert "0000000000000004" not in failed  # no verdict is not a failure


@pytest.mark.skipif(find_chromium() is None, reason="needs Chromium")
def test_chromium_draws_the_lead_the_alarm_and_the_figures(written, tmp_path):
    _, _, page = written
    shot = tmp_path / "report.png"
    assert screenshot_html(page, shot, window_size=(1000, 2600), timeout_s=60.0, attempts=2)
    rgb = (imread(shot)[..., :3] * 255).astype(int)
    dark = (rgb.max(axis=2) < 100).sum(axis=1)  # text, row by row
    assert dark[:120].sum() > 500, "no title or lead drawn at the top"
    red, green, blue = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    alarm = (red > 140) & (green < 40) & (blue < 40)  # the safety line's #a00
    assert alarm[:200].sum() > 200, "the contact alarm is not drawn in red"
    # matplotlib's first colour (#1f77b4), in the histograms and the figures' lines
    figure_blue = (abs(red - 31) < 25) & (abs(green - 119) < 25) & (abs(blue - 180) < 25)
    assert figure_blue.sum() > 300, "no figure drawn"
    assert np.argmax(figure_blue.any(axis=1)) > 200  # below the tables, where the figures are


@pytest.mark.parametrize(
    "source, campaign",
    [
        (None, "fake"),  # a store from before the source was kept
        ("/elsewhere/scenarios/bundled/campaigns/fake.yaml", "fake"),  # bundled, any install
        ("/home/me/my campaigns/fake.yaml", "'/home/me/my campaigns/fake.yaml'"),  # a file
    ],
)
def test_a_rerun_names_the_campaign_as_the_sweep_was_given_it(source, campaign):
    meta = {"campaign_name": "fake", "campaign_source": source}
    command = rerun_command(meta, "runs/my results", "00ff")
    assert command == f"rpod sweep {campaign} --out 'runs/my results' --rerun 00ff"
