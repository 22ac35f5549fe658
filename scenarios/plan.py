"""Any planner's plan to a folder: plan.npz, summary.json, plots/, scenario.yaml (`rpod plan`).

Owns: `plan_scenario` (the scenario's controller's `make_plan`, rpod.diagrams.controller_seam: the
plan from the initial state, no simulation) and `plan_to_folder`, which writes the plug-in's
`PlanOutput` the same way for every planner, so that a folder is either complete or absent (a
hidden staging folder renamed into place, as `rpod.scenarios.run.run_to_folder` does), under the
same rules for the output folder (`rpod.scenarios.run.check_out_dir`: checked before planning,
and a folder rpod did not write is only replaced with `overwrite`).
Does not own: the planners, what their arrays and summaries hold (each plug-in documents its
plan file, e.g. rpod.diagrams.controllers.soft_capture.plan_file), or the command line.

summary.json leads with `scenario`, `status` (the planner's word), `passed` (the planner
succeeded and the independent check passed: `rpod plan` exits 0) and `reason`, then the
plug-in's entries and `plots`; it is written last, so its presence marks a complete plan.
"""

from __future__ import annotations

import json
import logging
import pathlib

import numpy as np

from rpod.diagrams import controller_seam
from rpod.diagrams.scenario import Scenario, ScenarioError
from rpod.scenarios.loader import ScenarioFileError, dump_scenario
from rpod.scenarios.run import check_out_dir, staged_folder

_logger = logging.getLogger("rpod")


def plan_scenario(name: str, scenario: Scenario, closed_loop: bool = False):
    """The scenario's controller's plan from the initial state (its plug-in's `make_plan`).

    Raises:
        ScenarioFileError: If the scenario's controller has no planner, or the planner says a
            field makes planning impossible (one line naming the field).
    """
    plugin = controller_seam.plugin_for(scenario.controller)
    if plugin is None or plugin.make_plan is None:
        with_planner = [f"!{p.tag}" for p in controller_seam.controller_plugins() if p.make_plan]
        got = "none" if plugin is None else f"!{plugin.tag}"
        raise ScenarioFileError(
            f"{name}: controller: `rpod plan` needs a controller with a planner "
            f"({', '.join(with_planner)}), got {got}"
        )
    try:
        output = plugin.make_plan(scenario, closed_loop)
    except ScenarioError as error:
        raise ScenarioFileError(f"{name}: {error.field}: {error.message}") from None
    if not isinstance(output, controller_seam.PlanOutput):
        raise TypeError(
            f"!{plugin.tag}'s make_plan returned {type(output).__name__}, not a PlanOutput"
        )
    return output


def _write_figures(output, arrays: dict, out_dir: pathlib.Path, title: str) -> list[str]:
    """The plan's figures as PNGs; one that fails or has nothing to draw is skipped."""
    from rpod.diagrams.plots import save_figure  # matplotlib only when there is a plan to draw

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name, draw in output.figures.items():
        try:
            figure = draw(arrays, title)
            if figure is not None:
                save_figure(figure, out_dir / name)
                written.append(name)
        except Exception:  # a side output: never lose the others
            _logger.warning("plan plots: could not draw %s", name, exc_info=True)
    return written


def plan_to_folder(
    name: str,
    scenario: Scenario,
    out_dir: pathlib.Path,
    closed_loop: bool = False,
    overwrite: bool = False,
) -> dict:
    """Plans `scenario` and writes plan.npz, summary.json, plots/ and scenario.yaml into out_dir.

    Args:
        name: The scenario's name (titles, summary).
        scenario: A validated scenario whose controller has a planner.
        out_dir: The folder to write (replaced whole, atomically, when complete).
        closed_loop: Plan what the closed loop's first plan is (its margins), where the
            plug-in distinguishes.
        overwrite: Also replace a folder rpod did not write (`--overwrite`).

    Returns:
        The summary (summary.json's content).

    Raises:
        ScenarioFileError: If the scenario's controller has no planner, or out_dir may not be
            written (checked before planning).
    """
    check_out_dir(out_dir, overwrite)
    output = plan_scenario(name, scenario, closed_loop)
    with staged_folder(out_dir, overwrite) as staging:
        arrays = {key: np.asarray(value) for key, value in output.arrays.items()}
        np.savez_compressed(staging / "plan.npz", **arrays)
        (staging / "scenario.yaml").write_text(dump_scenario(scenario))
        summary = {
            "scenario": name,
            "status": output.status,
            "passed": bool(output.passed),
            "reason": output.reason,
            **output.summary,
        }
        summary["plots"] = _write_figures(output, arrays, staging / "plots", name)
        # summary.json last: its presence marks a complete plan inside the folder too.
        (staging / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary
