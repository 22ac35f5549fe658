"""Meshcat recordings: a headless Meshcat, start/save of a replay, and a headless screenshot.

This module owns the Meshcat instance's life around a run and the standalone HTML file
(`recording.html`). It does not draw anything; `rpod.systems.scene` does.

Typical use in a simulate():

    meshcat = make_headless_meshcat()
    ... RendezvousScene.AddToBuilder(builder, meshcat, config.scene, ...)
    start_recording(meshcat, fps=32.0)        # before Simulator.Initialize()
    simulator.AdvanceTo(t_final)
    save_recording_html(meshcat, out_dir / "recording.html")

`screenshot_html` renders such a file in headless Chromium so tests can check that something was
drawn. WebGL runs in software (SwiftShader): Chromium's automatic fallback to it is deprecated,
so `--enable-unsafe-swiftshader` opts in explicitly; `--use-gl=swiftshader` gives a blank page.
"""

from __future__ import annotations

import logging
import os
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path

from pydrake.geometry import Meshcat, MeshcatParams

# Flags for a quiet, offline, sandbox-free headless Chromium with software WebGL.
CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
)
CHROMIUM_CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def make_headless_meshcat(port: int = 0) -> Meshcat:
    """Creates a Meshcat server on localhost without the console banner or the stats plot.

    Args:
        port: TCP port; 0 picks a free ephemeral port (safe for parallel runs).
    """
    params = MeshcatParams()
    params.host = "localhost"
    params.port = port
    params.show_stats_plot = False
    drake_logger = logging.getLogger("drake")
    old_level = drake_logger.level
    drake_logger.setLevel(logging.WARNING)  # Hides "Meshcat listening for connections at ...".
    try:
        return Meshcat(params)
    finally:
        drake_logger.setLevel(old_level)


def start_recording(
    meshcat: Meshcat, fps: float = 32.0, set_visualizations_while_recording: bool = True
) -> None:
    """Starts recording transforms and properties that carry a time.

    Call it before `Simulator.Initialize()` so the initial state is part of the replay. `fps`
    only sets the time quantisation of key frames (keep it >= 1 / publish period); the file size
    depends on the number of publishes, not on `fps`.

    Args:
        meshcat: the Meshcat to record.
        fps: key-frame rate of the animation [1/s].
        set_visualizations_while_recording: also send every recorded call to the live scene;
            False saves work when nobody watches, but the HTML's scene tree then shows the pose
            at the start until the animation runs.
    """
    meshcat.StartRecording(
        frames_per_second=fps, set_visualizations_while_recording=set_visualizations_while_recording
    )


def save_recording_html(meshcat: Meshcat, path: str | os.PathLike) -> Path:
    """Stops the recording, attaches it as the animation, and writes standalone HTML atomically.

    The file is written to a temporary file in the same folder and then renamed over `path`, so a
    reader never sees a partial file. The HTML needs no server (scripts and data are inlined).

    Args:
        meshcat: the recorded Meshcat.
        path: output file, e.g. `runs/<scenario>/recording.html`; folders are created.

    Returns:
        The path written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    meshcat.StopRecording()
    meshcat.PublishRecording()
    html = meshcat.StaticHtml()
    fd, temp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(html)
        # mkstemp makes the file 0600; a recording is an output like any other (0666 & ~umask).
        os.chmod(temp_name, 0o666 & ~_umask())
        os.replace(temp_name, path)
    except BaseException:
        Path(temp_name).unlink(missing_ok=True)
        raise
    return path


def _umask() -> int:
    """The process's umask (os.umask can only be read by setting it)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def find_chromium() -> str | None:
    """Returns the path of a Chromium/Chrome executable on PATH, or None."""
    for candidate in CHROMIUM_CANDIDATES:
        found = shutil.which(candidate)
        if found:
            return found
    return None


def screenshot_html(
    html_path: str | os.PathLike,
    png_path: str | os.PathLike,
    timeout_s: float = 60.0,
    window_size: tuple[int, int] = (800, 600),
    virtual_time_budget_ms: int = 5000,
    chromium: str | None = None,
    script: str | None = None,
    attempts: int = 1,
) -> bool:
    """Renders an HTML file in headless Chromium and saves a PNG screenshot.

    The virtual time budget lets three.js load the inlined scene and draw some animation frames
    before the shot is taken.

    Args:
        html_path: the HTML file (e.g. a saved recording).
        png_path: the PNG to write.
        timeout_s: wall-clock limit for Chromium [s].
        window_size: (width, height) in pixels.
        virtual_time_budget_ms: page time Chromium lets pass before the shot [ms].
        chromium: executable; found on PATH when None.
        script: JavaScript run in the page after it loads (the Meshcat viewer is `viewer`),
            e.g. to pause the animation at a time or hide objects; the file itself is not
            changed (a copy with the script is rendered).
        attempts: Chromium started this many times at most, each with `timeout_s`: headless
            Chromium now and then never takes a virtual-time-budget shot (seen here once in
            ~10 suite runs: nothing after 240 s, on a page another start renders in 5 s).

    Returns:
        True if the PNG was written; False if Chromium is missing, fails or times out.
    """
    for _ in range(attempts):
        if _screenshot_once(
            html_path, png_path, timeout_s, window_size, virtual_time_budget_ms, chromium, script
        ):
            return True
    return False


def _screenshot_once(
    html_path, png_path, timeout_s, window_size, virtual_time_budget_ms, chromium, script
) -> bool:
    """One Chromium start of screenshot_html."""
    chromium = chromium or find_chromium()
    if chromium is None:
        return False
    html_path = Path(html_path).resolve()
    png_path = Path(png_path).resolve()
    png_path.unlink(missing_ok=True)
    with tempfile.TemporaryDirectory(prefix="rpod_chromium_") as user_data_dir:
        if script is not None:
            page = Path(user_data_dir) / "page.html"
            html = html_path.read_text(encoding="utf-8")
            at = html.rfind("</body>")
            page.write_text(f"{html[:at]}<script>{script}</script>\n{html[at:]}", "utf-8")
            html_path = page
        command = [
            chromium,
            *CHROMIUM_FLAGS,
            f"--user-data-dir={user_data_dir}",
            f"--window-size={window_size[0]},{window_size[1]}",
            f"--virtual-time-budget={virtual_time_budget_ms}",
            f"--screenshot={png_path}",
            html_path.as_uri(),
        ]
        try:
            # Own session, so a timeout can end Chromium's helper processes too.
            process = subprocess.Popen(
                command,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
            )
        except OSError:
            return False
        try:
            process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
            return False
    return png_path.is_file() and png_path.stat().st_size > 0
