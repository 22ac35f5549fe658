"""The `rpod` command line: run a scenario, sweep a campaign, report on it, list what is bundled.

Commands: `rpod run SCENARIO`, `rpod sweep CAMPAIGN`, `rpod report RESULTS`, `rpod export RUN`,
`rpod list`.

Exit status: 0 on success (`run`: the mission succeeded, or the scenario has no mission to
judge); 1 when a simulation failed (its outputs are written and its summary says why; for
`sweep`: every run is recorded and some failed; for `plan`: no plan passed the check); 2 on a
bad command line, file or field, with one line on stderr naming the file and field and no
traceback; 3 (`run`) when the simulation ran but the mission failed (no capture, hold point
not reached: the line says why); 130 when stopped by Ctrl-C and 143 by SIGTERM (nothing is
left half-written; `sweep` keeps every finished run and the same command resumes).
"""

import argparse
import logging
import os
import pathlib
import sys

from rpod.scenarios.loader import ScenarioFileError, bundled_scenarios, load_scenario

EXIT_SIMULATION_FAILED = 1
EXIT_BAD_INPUT = 2
EXIT_MISSION_FAILED = 3
DEFAULT_SCENARIO = "hold_point"
EXPORT_FORMATS = ("ccsds",)  # rpod.scenarios.export.FORMATS, without importing it to parse
SET_HELP = (
    "override one field, a dotted path with a YAML value (repeatable): "
    "--set chaser.mass_kg=400 --set 'chaser.p_LC_L=[0, -40, 0]' --set controller.hold_distance_m=5"
)
PLUGIN_HELP = (
    "load a controller plug-in first (repeatable): a module name or a Python file that calls "
    "rpod.diagrams.controller_seam.register_controller; sweeps pass it on to their workers "
    "through the RPOD_PLUGINS environment variable"
)


def _description(path: pathlib.Path) -> str:
    """The `description:` of a scenario file, read without building the scenario."""
    from rpod.scenarios.yaml_reader import YamlError, parse_yaml

    try:
        return str((parse_yaml(path.read_text()) or {}).get("description", ""))
    except (OSError, YamlError, AttributeError):
        return "(unreadable)"


def _cmd_list(args) -> int:
    from rpod.scenarios.campaign import bundled_campaigns

    scenarios, campaigns = bundled_scenarios(), bundled_campaigns()
    width = max(len(name) for name in [*scenarios, *campaigns])
    print("Scenarios (rpod run NAME):")
    for name, path in scenarios.items():
        print(f"  {name:<{width}}  {_description(path)}")
    print("Campaigns (rpod sweep NAME):")
    for name, path in campaigns.items():
        print(f"  {name:<{width}}  {_description(path)}")
    return 0


def _load_with_sets(name_or_path: str, sets: list[str]):
    """(name, scenario) of a scenario with the command line's `--set a.b=value` overrides.

    The value is YAML (`--set chaser.mass_kg=5e2`, `--set 'chaser.p_LC_L=[0, -40, 0]'`), the
    path a dotted Scenario field as in campaigns (rpod.scenarios.campaign.apply_overrides);
    every error is one line naming the flag.
    """
    name, scenario = load_scenario(name_or_path)
    if not sets:
        return name, scenario
    from rpod.diagrams.scenario import ScenarioError, validate_scenario
    from rpod.scenarios.campaign import apply_overrides, check_value
    from rpod.scenarios.loader import read_yaml
    from rpod.scenarios.schema import quote

    overrides = {}
    for item in sets:
        path, equals, text = item.partition("=")
        label = f"--set {quote(item)}"
        if not equals or not path.strip():
            raise ScenarioFileError(f"{label}: expected FIELD=VALUE, e.g. chaser.mass_kg=400")
        value = read_yaml(text, label)
        try:
            check_value(path.strip(), value, path.strip())
        except ScenarioError as error:
            raise ScenarioFileError(f"{label}: {error.field}: {error.message}") from None
        overrides[path.strip()] = value
    try:
        scenario = apply_overrides(scenario, overrides)
        validate_scenario(scenario)
    except ScenarioError as error:
        raise ScenarioFileError(
            f"{name_or_path} with --set: {error.field}: {error.message}"
        ) from None
    return name, scenario


def _cmd_plan(args) -> int:
    name, scenario = _load_with_sets(args.scenario, args.set)
    out_dir = pathlib.Path(args.out) if args.out else pathlib.Path("runs") / f"{name}-plan"
    from rpod.scenarios.plan import plan_to_folder  # heavy imports only when planning
    from rpod.scenarios.run import sigterm_as_interrupt

    with sigterm_as_interrupt():  # SIGTERM cleans up as Ctrl-C does (exit 143)
        summary = plan_to_folder(
            name, scenario, out_dir, closed_loop=args.closed_loop, overwrite=args.overwrite
        )
    margins = "the closed loop's margins" if args.closed_loop else "the scenario's tolerances"
    print(f"{name}: plan {summary['status']} with {margins}: {summary['reason']} -> {out_dir}")
    return 0 if summary["passed"] else 1


def _positive_number(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text}")
    return value


def _positive_integer(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text}")
    return value


def _non_negative_integer(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must not be negative, got {text}")
    return value


def _cmd_sweep(args) -> int:
    from rpod.scenarios.campaign import load_campaign, plan_runs
    from rpod.scenarios.sweep import check_workers, run_campaign  # Dask only when running

    check_workers(args.workers)  # before anything is loaded or started
    campaign = load_campaign(args.campaign)
    if args.seed is not None:
        campaign = campaign.with_seed(args.seed)
    runs = plan_runs(campaign)
    out_dir = pathlib.Path(args.out) if args.out else pathlib.Path("runs") / campaign.name
    if args.rerun:
        return _rerun(campaign, runs, args.rerun, out_dir, args)
    outcome = run_campaign(
        campaign,
        runs,
        out_dir,
        scheduler=args.scheduler,
        workers=args.workers,
        timeout_s=args.timeout_s if args.timeout_s is not None else campaign.timeout_s,
        save_runs=args.save_runs,
        record=args.record,
        retry_failed=args.retry_failed,
        reuse=args.reuse,
        connect_timeout_s=args.connect_timeout_s,
    )
    counts = outcome.counts
    summary = (
        f"{campaign.name}: {len(runs)} runs: {counts['ok']} ok, {counts['failed']} failed, "
        f"{counts['pending']} pending ({outcome.ran} run now) -> {outcome.store}"
    )
    if outcome.interrupted or outcome.lost_scheduler:
        why = "interrupted" if outcome.interrupted else "the cluster lost runs"
        print(
            f"rpod: {why}; finished runs are kept, run the same command to resume. {summary}",
            file=sys.stderr,
        )
        return 130 if outcome.interrupted else 1
    print(summary + f"\n  rpod report {out_dir}")
    return 0 if counts["failed"] == 0 else 1


def _rerun(campaign, runs, wanted: str, out_dir: pathlib.Path, args) -> int:
    """`rpod sweep CAMPAIGN --rerun RUN_ID`: one case again, with every output, into
    OUT/rerun/<run_id>/ (the store is not touched)."""
    from rpod.scenarios.campaign import apply_overrides
    from rpod.scenarios.run import run_to_folder, sigterm_as_interrupt
    from rpod.scenarios.schema import quote

    matches = [run for run in runs if run.run_id.startswith(wanted)] if wanted else []
    if len(matches) != 1:
        why = "matches no run" if not matches else f"matches {len(matches)} runs"
        raise ScenarioFileError(
            f"--rerun {quote(wanted)[1:-1]}: {why} of {campaign.source} ({len(runs)} runs; the ids are in "
            f"the store: sqlite3 {out_dir / 'results.sqlite'} 'select run_id, grp from runs')"
        )
    (run,) = matches
    scenario = apply_overrides(campaign.base, run.overrides)
    target = out_dir / "rerun" / run.run_id
    with sigterm_as_interrupt():
        summary = run_to_folder(run.run_id, scenario, target, record=True, overwrite=False)
    print(run_line(f"{campaign.name} {run.run_id} ({run.group})", summary, target))
    return run_exit_status(summary)


def _cmd_report(args) -> int:
    from rpod.scenarios.report import write_report
    from rpod.scenarios.store import store_path

    text, plots = write_report(
        args.results,
        out_dir=args.out,
        metrics=args.metrics,
        overwrite=args.overwrite,
        formats=tuple(args.format),
    )
    print(text)
    out = args.out or store_path(pathlib.Path(args.results)).parent / "report"
    tables = "".join(f", runs.{fmt}" for fmt in args.format)
    print(f"report.md, report.html{tables} and {len(plots)} plots -> {out}")
    return 0


def _export_line(run, written) -> str:
    """The one line `rpod export` (and `rpod run --export`) prints."""
    names = ", ".join(path.name for path in written)
    return f"{run}: CCSDS OEM and AEM (EME2000, UTC): {names} -> {written[0].parent}"


def _cmd_export(args) -> int:
    from rpod.scenarios.export import export_ccsds

    print(_export_line(args.run, export_ccsds(args.run, out_dir=args.out)))
    return 0


def _cmd_run(args) -> int:
    name, scenario = _load_with_sets(args.scenario, args.set)
    out_dir = pathlib.Path(args.out) if args.out else pathlib.Path("runs") / name
    if args.export:  # refused before a long run, not after it
        from rpod.scenarios.export import check_exportable

        check_exportable(scenario, args.scenario)
    from rpod.diagrams.scenario import scenario_warnings
    from rpod.scenarios.run import run_to_folder, sigterm_as_interrupt  # heavy: only to run

    said = scenario_warnings(scenario)
    for warning in said:  # at load, before a long run: what is legal but will likely fail
        print(f"rpod: warning: {warning}", file=sys.stderr)
    from rpod.scenarios.run_progress import RunProgress

    progress = RunProgress(name)
    try:
        with sigterm_as_interrupt():  # SIGTERM cleans up as Ctrl-C does (exit 143)
            summary = run_to_folder(
                name,
                scenario,
                out_dir,
                record=not args.no_record,
                overwrite=args.overwrite,
                progress=progress,
                plots=not args.no_plots,
            )
    finally:
        progress.done()
    for warning in summary.get("warnings", []):
        if warning not in said:  # the run's own (a plan that outlasts it), said at the end
            print(f"rpod: warning: {warning}", file=sys.stderr)
    print(run_line(name, summary, out_dir))
    if args.export:  # into the complete run folder, listed in its manifest (export.py)
        from rpod.scenarios.export import export_ccsds

        print(_export_line(out_dir, export_ccsds(out_dir)))
    return run_exit_status(summary)


def run_line(name: str, summary: dict, out_dir) -> str:
    """The one line `rpod run` prints: the mission outcome first, then what ran."""
    mission = summary.get("mission") or {}
    if summary["status"] != "ok":
        head = f"SIMULATION {summary['status'].upper()}"
    else:
        head = mission.get("outcome", "ran")
    navigation = summary.get("navigation")
    if navigation:  # flown on an estimate: say so, and how good it was, beside the outcome
        errors = navigation["errors"]
        head += (
            f"; on the EKF's estimate (position RMS {errors['position']['rms']:.3g} m, "
            f"attitude RMS {errors['attitude']['rms']:.2g} deg, "
            f"{navigation['fixes_rejected']} fixes rejected)"
        )
    return (
        f"{name}: {head}; {summary['sim_time_s']:.0f} s simulated in "
        f"{summary['wall_time_s']:.1f} s ({summary['real_time_factor']:.0f}x real time), "
        f"delta-v {summary['delta_v_m_s']:.3f} m/s, min separation "
        f"{summary['min_separation_m']:.2f} m -> {out_dir}"
    )


def run_exit_status(summary: dict) -> int:
    """0 mission succeeded (or none to judge), 1 simulation failed, 3 mission failed."""
    if summary["status"] != "ok":
        return EXIT_SIMULATION_FAILED
    if (summary.get("mission") or {}).get("success") is False:
        return EXIT_MISSION_FAILED
    return 0


class _OneLineErrorParser(argparse.ArgumentParser):
    """argparse, but a usage error is one stderr line (no usage block) and exit status 2."""

    def error(self, message: str):
        if len(message) > 200:  # argparse quotes the argument whole: a 5,000-digit --seed
            message = message[:197] + "..."
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see `{self.prog} --help`)\n")


def make_parser() -> argparse.ArgumentParser:
    """The argument parser of the `rpod` command (subcommands inherit its one-line errors)."""
    parser = _OneLineErrorParser(prog="rpod", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("run", help="build, simulate and write a scenario's outputs")
    run.add_argument(
        "scenario",
        nargs="?",
        default=DEFAULT_SCENARIO,
        help=f"a scenario file or the name of a bundled scenario (default: {DEFAULT_SCENARIO})",
    )
    run.add_argument("--out", help="output folder (default: runs/<scenario>)")
    run.add_argument("--no-record", action="store_true", help="skip the Meshcat recording")
    run.add_argument("--no-plots", action="store_true", help="skip the figures (plots/)")
    run.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", help=SET_HELP)
    run.add_argument(
        "--overwrite",
        action="store_true",
        help="replace --out even if it is a folder rpod did not write (once the run is "
        "complete; never a file)",
    )
    run.add_argument(
        "--export",
        choices=EXPORT_FORMATS,
        help="also write the chaser and target trajectories and attitudes into OUT/ccsds/ "
        "(CCSDS OEM and AEM, as `rpod export`)",
    )
    run.set_defaults(handler=_cmd_run)
    plan = commands.add_parser(
        "plan", help="run only the scenario's controller's planner and write the plan"
    )
    plan.add_argument("scenario", help="a scenario file or the name of a bundled scenario")
    plan.add_argument("--out", help="output folder (default: runs/<scenario>-plan)")
    plan.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE", help=SET_HELP)
    plan.add_argument(
        "--overwrite",
        action="store_true",
        help="replace --out even if it is a folder rpod did not write (once the plan is "
        "complete; never a file)",
    )
    plan.add_argument(
        "--closed-loop",
        action="store_true",
        help="plan with the closed loop's margins (the first plan `rpod run` flies) instead "
        "of the scenario's tolerances as written",
    )
    plan.set_defaults(handler=_cmd_plan)
    sweep = commands.add_parser(
        "sweep",
        help="run a campaign (grid, cases, samples); resumable",
        description="Run every run of a campaign and store the results as they finish. Run "
        "the same command again to resume: finished runs are not run again.",
    )
    sweep.add_argument("campaign", help="a campaign file or the name of a bundled campaign")
    sweep.add_argument("--out", help="output folder (default: runs/<campaign>)")
    sweep.add_argument(
        "--workers",
        type=_positive_integer,
        help="local worker processes (default: one per core; at most 4 per core)",
    )
    sweep.add_argument(
        "--scheduler", metavar="ADDRESS", help="use an existing Dask cluster, e.g. tcp://host:8786"
    )
    sweep.add_argument(
        "--timeout-s",
        type=_positive_number,
        help="fail a run that takes longer (default: the campaign's timeout_s, else none)",
    )
    sweep.add_argument(
        "--seed",
        type=_non_negative_integer,
        help="sampling seed (default: the campaign's sample.seed)",
    )
    sweep.add_argument(
        "--save-runs",
        action="store_true",
        help="also write each run's log.npz, plots and summary to OUT/runs/<id>/",
    )
    sweep.add_argument(
        "--record",
        action="store_true",
        help="also write each run's Meshcat recording (implies --save-runs)",
    )
    sweep.add_argument(
        "--retry-failed",
        action="store_true",
        help="run the failed runs again (their failures are kept in the store's retries table)",
    )
    sweep.add_argument(
        "--reuse",
        metavar="RESULTS",
        help="record the finished runs of another campaign's results folder whose ids are "
        "planned here instead of flying them again (an id is its run's whole scenario; the "
        "result is that of the code that flew it)",
    )
    sweep.add_argument(
        "--connect-timeout-s",
        type=_positive_number,
        default=10.0,
        help="how long to wait for the scheduler and a worker (default 10)",
    )
    sweep.add_argument(
        "--rerun",
        metavar="RUN_ID",
        help="run one stored case again (an id or a unique prefix) with every output (log, "
        "plots, recording) into OUT/rerun/<run_id>/; the store is not changed",
    )
    sweep.set_defaults(handler=_cmd_sweep)
    report = commands.add_parser("report", help="summarise a campaign's results, write plots")
    report.add_argument("results", help="a campaign output folder (or its results.sqlite)")
    report.add_argument("--out", help="plot folder (default: RESULTS/report)")
    report.add_argument(
        "--overwrite",
        action="store_true",
        help="write into --out even if it is a folder rpod report did not write (its files "
        "named as the report's are replaced; nothing else is touched)",
    )
    report.add_argument(
        "--metrics",
        type=lambda text: [m for m in text.split(",") if m],
        help="comma-separated metrics to summarise (default: all numeric)",
    )
    report.add_argument(
        "--format",
        type=lambda text: [f for f in text.split(",") if f],
        default=[],
        help="also write the runs as one table, one row per run with every override and "
        "metric: parquet (runs.parquet, units in its metadata), csv (runs.csv and "
        "runs.csv-metadata.json), or both (parquet,csv)",
    )
    report.set_defaults(handler=_cmd_report)
    export = commands.add_parser(
        "export",
        help="write a run's chaser and target as CCSDS OEM (trajectory) and AEM (attitude)",
    )
    export.add_argument("run", help="a run folder (rpod run's --out)")
    export.add_argument(
        "--format", choices=EXPORT_FORMATS, default="ccsds", help="file format (default: ccsds)"
    )
    export.add_argument("--out", help="output folder (default: RUN/ccsds)")
    export.set_defaults(handler=_cmd_export)
    listing = commands.add_parser("list", help="list bundled scenarios and campaigns")
    listing.set_defaults(handler=_cmd_list)
    for command in (run, plan, sweep, report, export):
        command.add_argument(
            "--plugin", action="append", default=[], metavar="MODULE_OR_FILE", help=PLUGIN_HELP
        )
    return parser


def _load_plugins(specs: list[str]) -> None:
    """Imports the `--plugin` modules (they register their controllers) and names them in
    RPOD_PLUGINS for the processes a sweep starts; ScenarioFileError (one line) on a failure."""
    from rpod.diagrams.controller_seam import PluginLoadError, load_plugin, remember_plugin

    for spec in specs:
        try:
            load_plugin(spec)
        except PluginLoadError as error:
            raise ScenarioFileError(str(error)) from None
        remember_plugin(spec)


class _StderrHandler(logging.Handler):
    """Writes to the sys.stderr of the moment (a test may have replaced it since)."""

    def emit(self, record):
        print(self.format(record), file=sys.stderr)


def _say_compiles() -> None:
    """One-time compiles (rpod.compile, e.g. the NMPC's C derivatives) said on stderr."""
    log = logging.getLogger("rpod.compile")
    if not log.handlers:
        handler = _StderrHandler()
        handler.setFormatter(logging.Formatter("rpod: %(message)s"))
        log.addHandler(handler)
        log.setLevel(logging.INFO)
        log.propagate = False


interrupted_in_an_import = False
"""Whether the last `main` was stopped inside an import (a command imports pydrake at use): the
console script then ends without the interpreter's finalisation (rpod.scenarios.entry says why)."""


def _raised_in_an_import(error: BaseException) -> bool:
    """True when the error's traceback passes through Python's import machinery."""
    frame = error.__traceback__
    while frame is not None:
        if frame.tb_frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.tb_next
    return False


def main(argv=None) -> int:
    """Entry point of the `rpod` console script."""
    logging.getLogger("drake").setLevel(logging.WARNING)
    _say_compiles()
    args = make_parser().parse_args(argv)
    try:
        _load_plugins(getattr(args, "plugin", []))
        return args.handler(args)
    except ScenarioFileError as error:
        print(f"rpod: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as interrupt:  # Ctrl-C: 130; SIGTERM (run.Terminated): 143
        global interrupted_in_an_import
        interrupted_in_an_import = _raised_in_an_import(interrupt)
        print(f"rpod: {getattr(interrupt, 'message', 'interrupted')}", file=sys.stderr)
        return getattr(interrupt, "exit_status", 130)
    except BrokenPipeError:  # `rpod report ... | head`: the reader left; no traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # nothing more to flush
        return 0


if __name__ == "__main__":
    sys.exit(main())
