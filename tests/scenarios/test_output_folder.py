"""The output folder of `rpod run` and `rpod plan` (`--out`): rpod replaces only what it wrote.

A folder rpod did not write, a file, the current folder or one containing it, the home folder,
a path under a file and a place where nothing can be created are refused with exit status 2 and
one stderr line naming --out, before anything is simulated (the run scenario here would take
~20 minutes, far past the subprocess timeout), and nothing there changes. `--overwrite` replaces
a folder rpod did not write, never a file. A re-run replaces rpod's own output (with the
`.rpod-output` manifest, or an older output without it). What killed runs left beside the
folder (`.NAME.partial-PID`, `.NAME.old-PID` of a dead PID) is cleaned up by the next run.

CLI cases run the command line's `main` in this process (`run_rpod_in_process`), with a timeout;
test_cli_bad_input checks that it says what the console entry point says.
"""

import hashlib
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys

import pytest
from campaign_helpers import run_rpod as run_rpod_process
from campaign_helpers import run_rpod_in_process

from rpod.scenarios.loader import ScenarioFileError, bundled_scenarios
from rpod.scenarios.run import MANIFEST, check_out_dir, staged_folder

TIMEOUT_S = 120  # bound on every subprocess; a run of LONG_DURATION_S would take ~20 min
LONG_DURATION_S = 100_000.0
SHORT_DURATION_S = 5.0
# A run completed and wrote its folder: 0, or 3 (`rpod run`: the simulation ran, the mission
# failed: 5 s is too short to reach the hold point). The folder is what these tests are about.
RAN = (0, 3)


def run_rpod(*args, cwd, env=None):
    """`rpod ARGS` in this process: the completed process's exit status, stdout and stderr."""
    return run_rpod_in_process(*args, cwd=cwd, env=env, timeout=TIMEOUT_S)


def assert_one_line_error(process, *must_contain):
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1, process.stderr  # one line, so no traceback
    assert lines[0].startswith("rpod: error: --out "), lines[0]
    for text in must_contain:
        assert text in lines[0], lines[0]


def hold_point_file(folder: pathlib.Path, duration_s: float) -> pathlib.Path:
    """The bundled hold_point scenario with another duration_s, written into folder."""
    text = bundled_scenarios()["hold_point"].read_text()
    text, count = re.subn(r"(?m)^duration_s: .*$", f"duration_s: {duration_s}", text)
    assert count == 1
    path = folder / f"hold_point_{duration_s:g}s.yaml"
    path.write_text(text)
    return path


def snapshot(folder: pathlib.Path) -> dict:
    """Every entry under folder (hidden ones too) -> a hash of its bytes, or 'dir'."""
    return {
        str(p.relative_to(folder)): "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).digest()
        for p in sorted(folder.rglob("*"))
    }


def hidden_siblings(out: pathlib.Path) -> list[str]:
    return sorted(p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}."))


def foreign_folder(path: pathlib.Path) -> pathlib.Path:
    """A folder rpod did not write: a file and a subfolder with a file."""
    (path / "sub").mkdir(parents=True)
    (path / "notes.txt").write_text("my notes\n")
    (path / "sub" / "data.csv").write_text("1,2,3\n")
    return path


@pytest.fixture(scope="module")
def scenarios(tmp_path_factory):
    """{'long': a run that would take ~20 min, 'short': a run of a second or two}."""
    folder = tmp_path_factory.mktemp("scenarios")
    return {
        "long": hold_point_file(folder, LONG_DURATION_S),
        "short": hold_point_file(folder, SHORT_DURATION_S),
    }


@pytest.fixture(scope="module")
def complete_run(tmp_path_factory, scenarios):
    """A complete `rpod run` output folder (copy it before changing it)."""
    out = tmp_path_factory.mktemp("complete") / "run"
    process = run_rpod(
        "run", str(scenarios["short"]), "--out", str(out), "--no-record", cwd=out.parent
    )
    assert process.returncode in RAN, process.stderr
    return out


def command(kind: str, scenarios) -> list[str]:
    """`rpod run` of the long scenario, or `rpod plan` of the bundled soft capture."""
    if kind == "run":
        return ["run", str(scenarios["long"]), "--no-record"]
    return ["plan", "soft_capture"]


KINDS = ["run", "plan"]


# ---------------------------------------------------------------------------------------------
# Refused, exit 2, nothing changed.


@pytest.mark.parametrize("kind", KINDS)
def test_a_folder_rpod_did_not_write_is_refused_and_kept(tmp_path, scenarios, kind):
    out = foreign_folder(tmp_path / "mine")
    before = snapshot(tmp_path)
    process = run_rpod(*command(kind, scenarios), "--out", str(out), cwd=tmp_path)
    assert_one_line_error(process, str(out), "notes.txt", "--overwrite")
    assert snapshot(tmp_path) == before


def test_an_rpod_output_with_a_file_added_is_refused(tmp_path, scenarios, complete_run):
    out = tmp_path / "run"
    shutil.copytree(complete_run, out)
    (out / "notes.txt").write_text("my notes\n")
    before = snapshot(tmp_path)
    process = run_rpod(*command("run", scenarios), "--out", str(out), cwd=tmp_path)
    assert_one_line_error(process, "notes.txt", "--overwrite")
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("overwrite", [False, True], ids=["plain", "overwrite"])
@pytest.mark.parametrize("kind", KINDS)
def test_a_file_is_refused_even_with_overwrite(tmp_path, scenarios, kind, overwrite):
    out = tmp_path / "results.csv"
    out.write_text("a,b\n1,2\n")
    before = snapshot(tmp_path)
    flags = ["--overwrite"] if overwrite else []
    process = run_rpod(*command(kind, scenarios), "--out", str(out), *flags, cwd=tmp_path)
    assert_one_line_error(process, "results.csv", "is a file")
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize(
    "out, what",
    [
        (".", "is the current folder"),
        ("..", "contains the current folder"),
        ("/", "is the filesystem root"),
        ("HOME", "is the home folder"),
        ("CWD", "is the current folder"),
    ],
)
def test_the_current_folder_its_ancestors_and_home_are_refused(tmp_path, scenarios, out, what):
    """Even with --overwrite: rpod would rename them away."""
    work, home = tmp_path / "work", tmp_path / "home"
    for folder in (work, home):
        folder.mkdir()
        (folder / "precious.txt").write_text("keep me\n")
    out = {"HOME": str(home), "CWD": str(work)}.get(out, out)
    env = {**os.environ, "HOME": str(home), "MPLCONFIGDIR": str(tmp_path / "mpl")}
    before = {p: snapshot(p) for p in (work, home)}
    process = run_rpod(*command("run", scenarios), "--out", out, "--overwrite", cwd=work, env=env)
    assert_one_line_error(process, what)
    assert {p: snapshot(p) for p in (work, home)} == before
    assert sorted(p.name for p in tmp_path.iterdir()) in (["home", "work"], ["home", "mpl", "work"])


@pytest.mark.parametrize("kind", KINDS)
def test_a_path_under_a_file_is_refused(tmp_path, scenarios, kind):
    (tmp_path / "somefile").write_text("x\n")
    process = run_rpod(*command(kind, scenarios), "--out", "somefile/out", cwd=tmp_path)
    assert_one_line_error(process, "somefile", "is not a folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["somefile"]


@pytest.mark.parametrize("kind", KINDS)
def test_a_place_where_nothing_can_be_created_is_refused(tmp_path, scenarios, kind):
    """/proc refuses new folders even to root (chmod would not stop root)."""
    process = run_rpod(*command(kind, scenarios), "--out", "/proc/rpod-test/out", cwd=tmp_path)
    assert_one_line_error(process, "/proc/rpod-test/out", "cannot create")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------------------------
# Used: nothing there, an empty folder, rpod's own output; --overwrite.


def _assert_run_output(out: pathlib.Path):
    names = {p.name for p in out.iterdir()}
    assert {"summary.json", "log.npz", "scenario.yaml", "plots", MANIFEST} <= names
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["written_by"] == "rpod"
    assert set(manifest["entries"]) == {
        str(p.relative_to(out)) for p in out.rglob("*") if p.name != MANIFEST
    }
    assert hidden_siblings(out) == []


def test_an_empty_folder_is_used(tmp_path, scenarios):
    out = tmp_path / "empty"
    out.mkdir()
    process = run_rpod(
        "run", str(scenarios["short"]), "--out", str(out), "--no-record", cwd=tmp_path
    )
    assert process.returncode in RAN, process.stderr
    _assert_run_output(out)


@pytest.mark.parametrize("manifest", [True, False], ids=["manifest", "older_output"])
def test_a_rerun_replaces_rpods_own_output(tmp_path, scenarios, complete_run, manifest):
    """With the manifest, or an older output (summary.json, scenario.yaml, log.npz) without it."""
    out = tmp_path / "run"
    shutil.copytree(complete_run, out)
    if not manifest:
        (out / MANIFEST).unlink()
    removed = min((out / "plots").iterdir())
    removed.unlink()  # entries may be missing: still rpod's
    process = run_rpod(
        "run", str(scenarios["short"]), "--out", str(out), "--no-record", cwd=tmp_path
    )
    assert process.returncode in RAN, process.stderr
    _assert_run_output(out)
    assert removed.exists()


def test_a_plan_replaces_its_own_output(tmp_path):
    out = tmp_path / "plan"
    for _ in range(2):
        process = run_rpod("plan", "soft_capture", "--out", str(out), cwd=tmp_path)
        assert process.returncode == 0, process.stderr
    assert {"plan.npz", "summary.json", "scenario.yaml", "plots", MANIFEST} <= {
        p.name for p in out.iterdir()
    }
    assert hidden_siblings(out) == []


@pytest.mark.parametrize("kind", KINDS)
def test_overwrite_replaces_a_folder_rpod_did_not_write(tmp_path, scenarios, kind):
    out = foreign_folder(tmp_path / "mine")
    args = (
        ["run", str(scenarios["short"]), "--no-record"]
        if kind == "run"
        else ["plan", "soft_capture"]
    )
    process = run_rpod(*args, "--out", str(out), "--overwrite", cwd=tmp_path)
    assert process.returncode in RAN, process.stderr
    assert not (out / "notes.txt").exists() and not (out / "sub").exists()
    assert (out / "summary.json").is_file() and (out / MANIFEST).is_file()
    assert hidden_siblings(out) == []


# ---------------------------------------------------------------------------------------------
# What killed runs left.


def dead_pid() -> int:
    """The PID of a process that has exited and been reaped."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait(timeout=TIMEOUT_S)
    try:
        os.kill(child.pid, 0)
    except ProcessLookupError:
        return child.pid
    pytest.skip("the PID was reused at once")


def test_a_run_removes_what_a_killed_run_left(tmp_path, scenarios):
    """A SIGKILLed run leaves `.out.partial-PID`; the next run into out removes it."""
    out = tmp_path / "out"
    leftover = tmp_path / f".out.partial-{dead_pid()}"
    (leftover / "plots").mkdir(parents=True)
    (leftover / "log.npz").write_bytes(b"half written")
    live = tmp_path / f".out.partial-{os.getpid()}"  # a concurrent run's staging: kept
    live.mkdir()
    process = run_rpod_process(  # its own process: this one plays the concurrent run
        "run", str(scenarios["short"]), "--out", str(out), "--no-record", cwd=tmp_path
    )
    assert process.returncode in RAN, process.stderr
    assert not leftover.exists()
    assert live.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([out.name, live.name])


def test_a_killed_runs_retired_output_is_removed_or_restored(tmp_path):
    """`.out.old-PID` (killed between its two renames): removed if out exists, else restored."""
    out, retired = tmp_path / "out", tmp_path / f".out.old-{dead_pid()}"
    for text in ("previous", "current"):
        with staged_folder(out) as staging:
            _write(staging, text)
        if text == "previous":
            out.rename(retired)
    check_out_dir(out)
    assert not retired.exists() and (out / "summary.json").read_text() == "current"

    out.rename(retired)
    check_out_dir(out)
    assert not retired.exists() and (out / "summary.json").read_text() == "current"


# ---------------------------------------------------------------------------------------------
# staged_folder's contract (the campaign engine writes OUT/runs/<id> through it).


def _write(folder: pathlib.Path, text: str):
    (folder / "plots").mkdir()
    (folder / "plots" / "a.png").write_bytes(b"png")
    (folder / "summary.json").write_text(text)


def test_staged_folder_replaces_its_own_output_and_refuses_others(tmp_path):
    out = tmp_path / "runs" / "run-0001"
    for text in ("first", "second"):
        with staged_folder(out) as staging:
            _write(staging, text)
        assert (out / "summary.json").read_text() == text
    assert hidden_siblings(out) == []
    (out / "notes.txt").write_text("mine")
    before = snapshot(tmp_path)
    with pytest.raises(ScenarioFileError, match="notes.txt"), staged_folder(out):
        pytest.fail("must not be reached")
    assert snapshot(tmp_path) == before


def test_staged_folder_keeps_the_previous_output_when_the_body_fails(tmp_path):
    out = tmp_path / "out"
    with staged_folder(out) as staging:
        _write(staging, "complete")
    before = snapshot(tmp_path)
    with pytest.raises(KeyboardInterrupt), staged_folder(out) as staging:
        _write(staging, "half")
        raise KeyboardInterrupt
    assert snapshot(tmp_path) == before


def test_staged_folder_does_not_replace_what_appeared_during_the_run(tmp_path):
    """Checked again before the rename: a folder created meanwhile by someone else is kept."""
    out = tmp_path / "out"
    with pytest.raises(ScenarioFileError, match="notes.txt"), staged_folder(out) as staging:
        _write(staging, "complete")
        foreign_folder(out)
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "sub"]
    assert hidden_siblings(out) == []


def test_a_symbolic_link_is_refused(tmp_path):
    target = foreign_folder(tmp_path / "target")
    link = tmp_path / "link"
    link.symlink_to(target)
    with pytest.raises(ScenarioFileError, match="symbolic link"):
        check_out_dir(link, overwrite=True)
    assert link.is_symlink() and (target / "notes.txt").exists()
