"""Every bundled scenario's recording.html opens with both bodies in the picture.

The recording is rendered in headless Chromium (rpod.diagrams.recording.screenshot_html) with a
script that pauses the replay at its first or last instant and hides everything but one body
(its own box or hull; the grid, the axes, the overlays, a method's extras and the other body
hidden): the non-white pixels left are that body's, as the camera rpod chose shows it. A camera
beyond Meshcat's far plane, or pointed away, leaves none.
"""

import json

import matplotlib.image as mpimg
import numpy as np
import pytest

from rpod.diagrams.recording import find_chromium, screenshot_html
from rpod.scenarios import cli
from rpod.scenarios.loader import bundled_scenarios

pytestmark = pytest.mark.skipif(find_chromium() is None, reason="needs Chromium")

WINDOW = (800, 600)
CONTROLS_ROWS = 24  # Meshcat's "Open Controls" bar at the top right is not the scene
MIN_BODY_PIXELS = 12  # a body a few pixels across is visible; zero means out of the view
# Chromium's own limit per shot [s], and starts per shot. asteroid_grasp's recording loaded in
# 17-22 s here before its trail was thinned (4.8 s after) and once passed 60 s on a loaded CI
# machine; and a headless Chromium now and then never takes its shot at all (once in ~10 suite
# runs here: 240 s of nothing on the coast, which another start renders in 5 s). The test is
# about what the picture shows, not how fast a software-rendered page loads.
SHOT_TIMEOUT_S = 120.0
SHOT_ATTEMPTS = 3

ISOLATE = """
setTimeout(function() {
  const body = %(body)s, seek = %(seek)s;
  const hide = (path) => viewer.handle_command(
      {type: "set_property", path: path, property: "visible", value: false});
  ["/Grid", "/Axes", "/Background"].forEach(hide);
  const rpod = viewer.scene_tree.find(["drake", "rpod"]);
  for (const name of Object.keys(rpod.children))
    if (name !== "bodies") hide("/drake/rpod/" + name);
  const bodies = rpod.children["bodies"];
  for (const name of Object.keys(bodies.children)) {
    if (name !== body) { hide("/drake/rpod/bodies/" + name); continue; }
    for (const child of Object.keys(bodies.children[name].children))
      if (child !== body + "_box" && child !== body + "_hull" && child !== "locator")
        hide("/drake/rpod/bodies/" + name + "/" + child);
  }
  viewer.animator.pause();
  viewer.animator.seek(seek < 0 ? viewer.animator.duration : seek);
}, 1500);
"""


def body_pixels(html, body: str, last: bool, png) -> int:
    """Pixels of one body in the rendered recording, at its first or last instant."""
    script = ISOLATE % {"body": json.dumps(body), "seek": -1 if last else 0}
    assert screenshot_html(html, png, SHOT_TIMEOUT_S, WINDOW, script=script, attempts=SHOT_ATTEMPTS)
    image = mpimg.imread(png)[CONTROLS_ROWS:, :, :3]
    return int(np.count_nonzero(image.sum(axis=-1) < 2.9))


def _check(name: str, tmp_path) -> None:
    out = tmp_path / name
    assert cli.main(["run", name, "--out", str(out)]) in (0, 3)  # 3: the mission failed
    html = out / "recording.html"
    total = WINDOW[0] * (WINDOW[1] - CONTROLS_ROWS)
    for body in ("target", "chaser"):
        for last in (False, True):
            pixels = body_pixels(html, body, last, tmp_path / f"{name}_{body}_{last}.png")
            when = "last" if last else "first"
            assert pixels >= MIN_BODY_PIXELS, f"{name}: the {body} is not in the {when} frame"
            assert pixels < 0.5 * total, f"{name}: the {body} fills the {when} frame"


# The three kinds that opened blank (camera beyond the 100 m far plane). The coast, the
# cheapest flight, is run by default: the camera and the far plane are set by one framing code
# for every method (systems/scene.py, from the box of what the run drew). The other two are
# slow, as is every bundled scenario below.
@pytest.mark.parametrize(
    "name",
    [
        "coast",
        pytest.param("los_corridor", marks=pytest.mark.slow),
        pytest.param("asteroid_grasp", marks=pytest.mark.slow),
    ],
)
def test_far_scenes_show_both_bodies(name, tmp_path):
    _check(name, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(bundled_scenarios()))
def test_every_bundled_recording_shows_both_bodies(name, tmp_path):
    _check(name, tmp_path)
