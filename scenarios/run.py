"""One scenario run to a folder: summary.json, log.npz, recording.html, plots/, scenario.yaml.

Owns: `run_to_folder`, which simulates a loaded scenario and writes its outputs so that a
folder is either complete or absent: everything is written into a hidden sibling folder first
and renamed into place at the end (a run that dies leaves no `runs/<name>/` looking complete,
and a previous complete run of the same name is only replaced by a complete one). Also the
rules for the output folder that `rpod run` and `rpod plan` share (`check_out_dir`,
`staged_folder`) and SIGTERM handling (`sigterm_as_interrupt`).
Does not own: parsing (loader.py) or the command line (cli.py).

The output folder (`--out`). rpod replaces its output folder whole, so it only replaces what
it wrote itself. Checked before anything is simulated, cheapest first; a refusal is a
`ScenarioFileError` (one line, exit 2) and changes nothing at that path (only what killed
runs left beside it is cleaned up, below):
- Never the filesystem root, the current folder, the home folder, or a folder containing
  either (rpod would rename them away), nor a mount point or a symbolic link (rpod would
  replace the link, not write where it points).
- The nearest existing ancestor must be a folder in which a folder can be created (tried with
  an empty probe folder, removed at once): `somefile/out` and `/proc/x/out` are refused.
- What is at the path: nothing, or an empty folder: used. A folder rpod wrote (below): replaced
  once the new output is complete. Any other folder: refused, unless `overwrite` (`--overwrite`)
  is given, in which case it too is replaced once the new output is complete. A file (or
  anything else that is not a folder): always refused, even with `overwrite`: `--overwrite`
  replaces an output *folder*, and a file at that path is more likely a typo than old output.

Which folders rpod wrote. `staged_folder` writes a manifest, `.rpod-output` (JSON:
{"written_by": "rpod", "format": 1, "entries": [every file and folder, relative, "/"-separated]}),
into every output folder as its last file before the rename. A folder holding a valid manifest
is rpod's when everything in it is listed there: entries may have been deleted, but a file or
folder added since (notes.txt) makes it somebody else's. A folder without a manifest (written
by rpod before the manifest existed) is rpod's when it holds summary.json (a JSON object with
"scenario", "status" and "plots"), scenario.yaml and log.npz or plan.npz, and nothing but
summary.json, scenario.yaml, log.npz, plan.npz, recording.html and plots/ (holding only .png
files).

What a killed run leaves. Ctrl-C, SIGTERM (under `sigterm_as_interrupt`) or an error remove the
staging folder. SIGKILL (or a crash) cannot be caught: it leaves `.NAME.partial-PID` beside
NAME, and, if it came between the two renames that put a new output in place,
`.NAME.old-PID` (the previous output). The next `check_out_dir` of NAME cleans them up when
process PID is no longer alive (os.kill(PID, 0); a live PID, which may be a concurrent run into
the same place, is left alone): a `.partial-` (or an empty `.probe-`, from the check of the
parent) is removed; an `.old-` is removed when NAME exists (its replacement was complete), else
renamed back to NAME (the previous output is restored, as if the killed run had never
finished). PIDs are those of this machine: in a folder shared by runs on several machines, the
live staging of another machine's run may be removed (that run then fails at its rename).
"""

import contextlib
import itertools
import json
import os
import pathlib
import re
import shutil
import signal
import threading

import numpy as np

from rpod.diagrams.controller_seam import plugin_for
from rpod.diagrams.plots import write_plots
from rpod.diagrams.scenario import Scenario
from rpod.diagrams.simulate import simulate
from rpod.models.config import ConfigError
from rpod.scenarios.loader import ScenarioFileError, dump_scenario
from rpod.scenarios.schema import quote

MANIFEST = ".rpod-output"  # the list of what rpod wrote, in every output folder
MANIFEST_FORMAT = 1
# What rpod wrote into an output folder before it wrote the manifest.
LEGACY_NAMES = {"summary.json", "scenario.yaml", "log.npz", "plan.npz", "recording.html", "plots"}
LEGACY_SUMMARY_KEYS = {"scenario", "status", "plots"}
PATH_QUOTE_CHARS = 200  # paths are quoted whole up to this length (loader.quote)
SHOWN_NAMES = 3  # foreign entries named in a refusal


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the signal arrives so that cleanup runs as for Ctrl-C.

    A KeyboardInterrupt so that every `except KeyboardInterrupt` (and `staged_folder`'s
    cleanup) treats it as an interruption; `exit_status` is what the command line returns.
    """

    exit_status = 128 + signal.SIGTERM  # 143
    message = "terminated (SIGTERM)"


@contextlib.contextmanager
def sigterm_as_interrupt():
    """Within the block, SIGTERM raises `Terminated` (once) instead of killing the process.

    Left alone when SIGTERM is not at its default (ignored, as under some supervisors, or
    handled by the caller), or off the main thread, where Python cannot install handlers.
    """
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    ):
        yield
        return
    fired = False

    def handler(signum, frame):
        nonlocal fired
        if not fired:  # a second SIGTERM must not interrupt the cleanup of the first
            fired = True
            raise Terminated()

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _q(path) -> str:
    return quote(str(path), PATH_QUOTE_CHARS)


def _absolute(out_dir) -> pathlib.Path:
    """out_dir made absolute, its parent's symbolic links resolved, its own name kept."""
    path = pathlib.Path(out_dir)
    if path.name in ("", ".."):  # ".", "/", "a/..": no name of its own
        return path.resolve()
    return path.parent.resolve() / path.name


def _ancestors_and_self(path: pathlib.Path) -> set[pathlib.Path]:
    return {path, *path.parents}


def _refuse_protected(label: str, out: pathlib.Path) -> None:
    """The root, the current folder, the home folder or a folder containing them: refused."""
    real = pathlib.Path(os.path.realpath(out))
    protected = []
    with contextlib.suppress(OSError):  # a current folder that was removed protects nothing
        protected.append((pathlib.Path(os.path.realpath(os.getcwd())), "the current folder"))
    with contextlib.suppress(RuntimeError, KeyError):
        protected.append((pathlib.Path(os.path.realpath(pathlib.Path.home())), "the home folder"))
    for folder, what in protected:
        if real in _ancestors_and_self(folder):
            is_what = (
                "is the filesystem root"
                if real == pathlib.Path(real.anchor)
                else f"is {what}"
                if real == folder
                else f"contains {what}"
            )
            raise ScenarioFileError(
                f"{label}: {is_what}, which rpod would replace whole; choose a folder of its "
                f"own, such as runs/NAME"
            )


def _check_parent(label: str, out: pathlib.Path) -> None:
    """The nearest existing ancestor of out is a folder where a folder can be created."""
    child, parent = out, out.parent
    while not os.path.lexists(parent):
        child, parent = parent, parent.parent
    if not parent.is_dir():
        raise ScenarioFileError(
            f"{label}: {_q(parent)} is not a folder, so nothing can be created under it"
        )
    probe = parent / f".{child.name}.probe-{os.getpid()}"
    try:
        probe.mkdir()
        probe.rmdir()
    except OSError as error:
        raise ScenarioFileError(
            f"{label}: cannot create folders in {_q(parent)}: {error.strerror}"
        ) from None


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # another user's process (or not a PID we can ask about): leave it
    return True


def remove_stale_staging(out: pathlib.Path) -> None:
    """Cleans up after killed runs into out (module docstring, "What a killed run leaves")."""
    pattern = re.compile(rf"\.{re.escape(out.name)}\.(partial|old|probe)-([0-9]+)")
    try:
        siblings = [p for p in os.scandir(out.parent) if pattern.fullmatch(p.name)]
    except OSError:
        return
    stale = []
    for entry in siblings:
        kind, pid = pattern.fullmatch(entry.name).groups()
        if int(pid) != os.getpid() and not _pid_alive(int(pid)):
            stale.append((kind, pathlib.Path(entry.path)))
    for kind, path in sorted(stale, key=lambda item: item[0] == "old"):  # partials first
        if kind == "old" and not os.path.lexists(out):
            with contextlib.suppress(OSError):  # not restored: left as it is
                os.replace(path, out)
            continue
        shutil.rmtree(path, ignore_errors=True)


def _entries(folder: pathlib.Path):
    """Every file and folder under folder, relative and "/"-separated (links not followed)."""

    def raise_error(error):
        raise error

    for root, dirs, files in os.walk(folder, onerror=raise_error):
        relative = pathlib.Path(root).relative_to(folder)
        for name in sorted(dirs) + sorted(files):
            yield (relative / name).as_posix()


def _write_manifest(folder: pathlib.Path) -> None:
    entries = sorted(_entries(folder))
    manifest = {"written_by": "rpod", "format": MANIFEST_FORMAT, "entries": entries}
    (folder / MANIFEST).write_text(json.dumps(manifest, indent=1) + "\n")


def _read_json(path: pathlib.Path, max_bytes: int = 10_000_000):
    """The JSON in a regular file, or None (absent, not a file, too big, not JSON)."""
    try:
        if not path.is_file() or path.is_symlink() or path.stat().st_size > max_bytes:
            return None
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _foreign_entries(folder: pathlib.Path) -> list[str] | None:
    """None when folder is an rpod output folder; else (some of) the entries rpod did not write.

    An empty list means it is not rpod's as a whole (no manifest and not an older rpod output).
    """
    manifest = _read_json(folder / MANIFEST)
    if (
        isinstance(manifest, dict)
        and manifest.get("written_by") == "rpod"
        and isinstance(manifest.get("entries"), list)
    ):
        known = {entry for entry in manifest["entries"] if isinstance(entry, str)} | {MANIFEST}
        try:
            foreign = [entry for entry in _entries(folder) if entry not in known]
        except OSError as error:
            return [f"{error.filename} ({error.strerror})"]
        return foreign[:SHOWN_NAMES] or None
    summary = _read_json(folder / "summary.json")
    if not (
        isinstance(summary, dict)
        and LEGACY_SUMMARY_KEYS <= summary.keys()
        and (folder / "scenario.yaml").is_file()
        and ((folder / "log.npz").is_file() or (folder / "plan.npz").is_file())
    ):
        return []
    foreign = sorted(p.name for p in folder.iterdir() if p.name not in LEGACY_NAMES)
    plots = folder / "plots"
    if plots.is_symlink() or (plots.exists() and not plots.is_dir()):
        foreign.append("plots")
    elif plots.is_dir():
        foreign += sorted(
            f"plots/{p.name}"
            for p in plots.iterdir()
            if p.suffix != ".png" or p.is_symlink() or not p.is_file()
        )
    return foreign[:SHOWN_NAMES] or None


def _some_names(folder: pathlib.Path) -> list[str]:
    """A few names in folder, "..." last if there are more (without listing a huge folder)."""
    with os.scandir(folder) as entries:
        names = sorted(entry.name for entry in itertools.islice(entries, 100))
    return [_q(name) for name in names[:SHOWN_NAMES]] + ["..."] * (len(names) > SHOWN_NAMES)


def _check_destination(label: str, out: pathlib.Path, overwrite: bool) -> None:
    """What is at out may be replaced (module docstring)."""
    if not os.path.lexists(out):
        return
    if out.is_symlink():
        raise ScenarioFileError(
            f"{label}: is a symbolic link; rpod would replace the link, not write where it "
            f"points: give the folder it points to, or remove the link"
        )
    if not out.is_dir():
        raise ScenarioFileError(
            f"{label}: is a file, not a folder; rpod does not replace files, even with "
            f"--overwrite: remove it or choose another --out"
        )
    if os.path.ismount(out):
        raise ScenarioFileError(
            f"{label}: is a mount point, which rpod cannot replace; choose a folder inside it"
        )
    if overwrite:
        return
    try:
        names = _some_names(out)
        foreign = _foreign_entries(out) if names else None
    except OSError as error:
        raise ScenarioFileError(f"{label}: cannot be read: {error.strerror}") from None
    if foreign is None:
        return
    if foreign:
        what = f"is an rpod output folder but also holds {', '.join(map(_q, foreign))}"
    else:
        what = f"is a folder that rpod did not write (it holds {', '.join(names)})"
    raise ScenarioFileError(
        f"{label}: {what}; rpod replaces its output folder whole, so choose another --out, "
        f"or pass --overwrite to replace this folder and everything in it"
    )


def check_out_dir(out_dir, overwrite: bool = False) -> pathlib.Path:
    """Checks that out_dir may be written (module docstring), cheapest checks first.

    Also cleans up what killed runs into out_dir left (`remove_stale_staging`).

    Args:
        out_dir: The output folder, as given.
        overwrite: Replace a folder rpod did not write (`--overwrite`).

    Returns:
        out_dir as an absolute path (the one `staged_folder` writes).

    Raises:
        ScenarioFileError: One line naming --out, why, and how to proceed.
    """
    label = f"--out {_q(out_dir)}"
    try:
        out = _absolute(out_dir)
    except (OSError, RuntimeError, ValueError) as error:  # RuntimeError: a symbolic link loop
        raise ScenarioFileError(f"{label}: cannot be resolved: {error}") from None
    _refuse_protected(label, out)
    _check_parent(label, out)
    remove_stale_staging(out)
    _check_destination(label, out, overwrite)
    return out


def _replace_folder(staging: pathlib.Path, destination: pathlib.Path) -> None:
    """Moves a finished staging folder to destination, replacing an older one."""
    retired = None
    if os.path.lexists(destination):
        retired = destination.with_name(f".{destination.name}.old-{os.getpid()}")
        shutil.rmtree(retired, ignore_errors=True)  # this process's own leftover
        os.replace(destination, retired)
    try:
        os.replace(staging, destination)
    except BaseException:
        if retired is not None:
            with contextlib.suppress(OSError):
                os.replace(retired, destination)  # put the previous output back
        raise
    if retired is not None:
        shutil.rmtree(retired, ignore_errors=True)


@contextlib.contextmanager
def staged_folder(out_dir: pathlib.Path, overwrite: bool = False):
    """Yields a hidden sibling folder to write into; renames it to out_dir only on success.

    out_dir is checked first (`check_out_dir`: a folder rpod did not write is only replaced
    with `overwrite`), and what is there checked again just before the rename. The manifest
    (module docstring) is written last. On any exception (Ctrl-C included) the staging folder
    is removed and out_dir is untouched, so a folder is either complete or absent.

    Raises:
        ScenarioFileError: If out_dir may not be written, or cannot be.
    """
    label = f"--out {_q(out_dir)}"
    out_dir = check_out_dir(out_dir, overwrite)
    staging = out_dir.with_name(f".{out_dir.name}.partial-{os.getpid()}")
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        shutil.rmtree(staging, ignore_errors=True)
        staging.mkdir()
    except OSError as error:
        raise ScenarioFileError(f"{label}: cannot create it: {error.strerror}") from None
    try:
        yield staging
        _write_manifest(staging)
        _check_destination(label, out_dir, overwrite)  # it may have changed during the run
        _replace_folder(staging, out_dir)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise


def run_to_folder(
    name: str,
    scenario: Scenario,
    out_dir: pathlib.Path,
    record: bool = True,
    overwrite: bool = False,
    progress=None,
    plots: bool = True,
) -> dict:
    """Simulates `scenario` and writes its outputs into out_dir; returns the summary.

    out_dir is checked before anything is simulated (`staged_folder`); with `overwrite`, a
    folder rpod did not write is replaced too (`--overwrite`). `progress` (a
    rpod.scenarios.run_progress.RunProgress, or None) is told the phases and the run's time.
    Without `record` there is no recording.html, without `plots` no plots/ (`--no-record`,
    `--no-plots`: ~2 s of a short run's matplotlib).
    """
    with staged_folder(out_dir, overwrite) as staging:
        meshcat = None
        if record:
            from rpod.diagrams.recording import make_headless_meshcat

            meshcat = make_headless_meshcat()
        if progress is not None:
            progress.phase("building the diagram and the controller's first plan")
        try:
            result = simulate(scenario, meshcat=meshcat, progress=progress)
        except ConfigError as error:  # found only as the diagram is built (a navigation lead-in)
            raise ScenarioFileError(f"{name}: {error}") from None
        if progress is not None:
            parts = ["the log", *(["the plots"] if plots else [])]
            parts += ["the recording"] if record else []
            last = parts.pop()
            progress.phase("writing " + (", ".join(parts) + " and " if parts else "") + last)
        summary = {"scenario": name, **result.summary}
        np.savez_compressed(staging / "log.npz", **result.log)
        (staging / "scenario.yaml").write_text(dump_scenario(scenario))
        summary["plots"] = []
        if plots:
            plugin = plugin_for(scenario.controller)  # its own figures beside the generic ones
            figures = [plugin] if plugin else []
            if "nav_p_LC_L" in result.log:  # flown on an estimate: the navigation's figure
                from rpod.diagrams.navigation_plots import NAVIGATION_FIGURES

                figures.append(NAVIGATION_FIGURES)
            written = write_plots(result.log, staging / "plots", name, figures)
            summary["plots"] = [p.name for p in written]
        if meshcat is not None:
            from rpod.diagrams.recording import save_recording_html

            save_recording_html(meshcat, staging / "recording.html")
        # summary.json last: its presence marks a complete run inside the folder too.
        (staging / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary
