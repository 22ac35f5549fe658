"""One scenario run to a folder: summary.json, log.npz, recording.html, plots/, scenario.yaml.

Owns: `run_to_folder`, which simulates a loaded scenario and writes its outputs so that a
folder is either complete or absent: everything is written into a hidden sibling folder first
and renamed into place at the end (a run that dies leaves no `runs/<name>/` looking complete,
and a previous complete run of the same name is only replaced by a complete one).
Does not own: parsing (loader.py) or the command line (cli.py).
"""

import contextlib
import json
import os
import pathlib
import shutil

import numpy as np
from pydrake.common.yaml import yaml_dump_typed

from rpod.diagrams.builder import simulate
from rpod.diagrams.plots import write_plots
from rpod.diagrams.scenario import Scenario


def _replace_folder(staging: pathlib.Path, destination: pathlib.Path) -> None:
    """Moves a finished staging folder to destination, replacing an older one."""
    retired = None
    if destination.exists():
        retired = destination.with_name(f".{destination.name}.old-{os.getpid()}")
        os.replace(destination, retired)
    os.replace(staging, destination)
    if retired is not None:
        shutil.rmtree(retired, ignore_errors=True)


@contextlib.contextmanager
def staged_folder(out_dir: pathlib.Path):
    """Yields a hidden sibling folder to write into; renames it to out_dir only on success.

    On any exception (Ctrl-C included) the staging folder is removed and out_dir is untouched,
    so a folder is either complete or absent.
    """
    out_dir = pathlib.Path(out_dir)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    staging = out_dir.with_name(f".{out_dir.name}.partial-{os.getpid()}")
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir()
    try:
        yield staging
        _replace_folder(staging, out_dir)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise


def run_to_folder(
    name: str, scenario: Scenario, out_dir: pathlib.Path, record: bool = True
) -> dict:
    """Simulates `scenario` and writes its outputs into out_dir; returns the summary."""
    with staged_folder(out_dir) as staging:
        meshcat = None
        if record:
            from rpod.diagrams.recording import make_headless_meshcat

            meshcat = make_headless_meshcat()
        result = simulate(scenario, meshcat=meshcat)
        summary = {"scenario": name, **result.summary}
        np.savez_compressed(staging / "log.npz", **result.log)
        (staging / "scenario.yaml").write_text(yaml_dump_typed(scenario))
        summary["plots"] = [p.name for p in write_plots(result.log, staging / "plots", name)]
        if meshcat is not None:
            from rpod.diagrams.recording import save_recording_html

            save_recording_html(meshcat, staging / "recording.html")
        # summary.json last: its presence marks a complete run inside the folder too.
        (staging / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary
