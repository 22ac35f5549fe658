"""The `rpod` command line: run a scenario, sweep a campaign, report on it, list what is bundled.

Commands: `rpod run SCENARIO`, `rpod sweep CAMPAIGN`, `rpod report RESULTS`, `rpod list`.

Exit status: 0 on success; 1 when a simulation ran but failed (its outputs are written and its
summary says why; for `sweep`: every run is recorded and some failed); 2 on a bad command line,
file or field, with one line on stderr naming the file and field and no traceback; 130 when
stopped by Ctrl-C (`sweep` keeps every finished run; the same command resumes).
"""

import argparse
import logging
import pathlib
import sys

from rpod.scenarios.loader import ScenarioFileError, bundled_scenarios, load_scenario

EXIT_BAD_INPUT = 2
DEFAULT_SCENARIO = "hold_point"


def _description(path: pathlib.Path) -> str:
    """The `description:` of a scenario file, read without building the scenario."""
    import yaml

    try:
        return str((yaml.safe_load(path.read_text()) or {}).get("description", ""))
    except (OSError, yaml.YAMLError, AttributeError):
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


def _cmd_plan(args) -> int:
    name, scenario = load_scenario(args.scenario)
    out_dir = pathlib.Path(args.out) if args.out else pathlib.Path("runs") / f"{name}-plan"
    from rpod.scenarios.plan import plan_to_folder  # heavy imports only when planning

    summary = plan_to_folder(name, scenario, out_dir)
    checked = bool(summary["check"] and summary["check"]["passed"])
    print(
        f"{name}: plan {summary['status']}, N = {summary.get('N')}, independent check "
        f"{'passed' if checked else 'FAILED'} -> {out_dir}"
    )
    return 0 if summary["status"] == "success" and checked else 1


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

    campaign = load_campaign(args.campaign)
    if args.seed is not None:
        campaign = campaign.with_seed(args.seed)
    runs = plan_runs(campaign)
    out_dir = pathlib.Path(args.out) if args.out else pathlib.Path("runs") / campaign.name
    from rpod.scenarios.sweep import run_campaign  # heavy imports only when running

    outcome = run_campaign(
        campaign, runs, out_dir,
        scheduler=args.scheduler, workers=args.workers,
        timeout_s=args.timeout_s if args.timeout_s is not None else campaign.timeout_s,
        save_runs=args.save_runs, record=args.record,
        connect_timeout_s=args.connect_timeout_s,
    )
    counts = outcome.counts
    summary = (f"{campaign.name}: {len(runs)} runs: {counts['ok']} ok, {counts['failed']} failed, "
               f"{counts['pending']} pending ({outcome.ran} run now) -> {outcome.store}")
    if outcome.interrupted or outcome.lost_scheduler:
        why = "interrupted" if outcome.interrupted else "the cluster lost runs"
        print(f"rpod: {why}; finished runs are kept, run the same command to resume. {summary}",
              file=sys.stderr)
        return 130 if outcome.interrupted else 1
    print(summary + f"\n  rpod report {out_dir}")
    return 0 if counts["failed"] == 0 else 1


def _cmd_report(args) -> int:
    from rpod.scenarios.report import write_report

    text, plots = write_report(args.results, out_dir=args.out, metrics=args.metrics)
    print(text)
    if plots:
        print(f"{len(plots)} plots -> {plots[0].parent}")
    return 0


def _cmd_run(args) -> int:
    name, scenario = load_scenario(args.scenario)
    out_dir = pathlib.Path(args.out) if args.out else pathlib.Path("runs") / name
    from rpod.scenarios.run import run_to_folder  # heavy imports only when running

    summary = run_to_folder(name, scenario, out_dir, record=not args.no_record)
    hold = summary.get("hold_reached")
    print(
        f"{name}: {summary['status']}, {summary['sim_time_s']:.0f} s simulated in "
        f"{summary['wall_time_s']:.1f} s ({summary['real_time_factor']:.0f}x real time), "
        f"delta-v {summary['delta_v_m_s']:.3f} m/s, min separation "
        f"{summary['min_separation_m']:.2f} m"
        + ("" if hold is None else f", hold point {'reached' if hold else 'NOT reached'}")
        + f" -> {out_dir}"
    )
    return 0 if summary["status"] == "ok" else 1


def make_parser() -> argparse.ArgumentParser:
    """The argument parser of the `rpod` command."""
    parser = argparse.ArgumentParser(prog="rpod", description=__doc__.splitlines()[0])
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
    run.set_defaults(handler=_cmd_run)
    plan = commands.add_parser(
        "plan", help="run only the scenario's planner and write the plan (soft capture)"
    )
    plan.add_argument("scenario", help="a scenario file or the name of a bundled scenario")
    plan.add_argument("--out", help="output folder (default: runs/<scenario>-plan)")
    plan.set_defaults(handler=_cmd_plan)
    sweep = commands.add_parser(
        "sweep", help="run a campaign (grid, cases, samples); resumable",
        description="Run every run of a campaign and store the results as they finish. Run "
                    "the same command again to resume: finished runs are not run again.")
    sweep.add_argument("campaign", help="a campaign file or the name of a bundled campaign")
    sweep.add_argument("--out", help="output folder (default: runs/<campaign>)")
    sweep.add_argument("--workers", type=_positive_integer,
                       help="local worker processes (default: one per core)")
    sweep.add_argument("--scheduler", metavar="ADDRESS",
                       help="use an existing Dask cluster, e.g. tcp://host:8786")
    sweep.add_argument("--timeout-s", type=_positive_number,
                       help="fail a run that takes longer (default: the campaign's timeout_s, "
                            "else none)")
    sweep.add_argument("--seed", type=_non_negative_integer,
                       help="sampling seed (default: the campaign's sample.seed)")
    sweep.add_argument("--save-runs", action="store_true",
                       help="also write each run's log.npz, plots and summary to OUT/runs/<id>/")
    sweep.add_argument("--record", action="store_true",
                       help="also write each run's Meshcat recording (implies --save-runs)")
    sweep.add_argument("--connect-timeout-s", type=_positive_number, default=10.0,
                       help="how long to wait for the scheduler and a worker (default 10)")
    sweep.set_defaults(handler=_cmd_sweep)
    report = commands.add_parser("report", help="summarise a campaign's results, write plots")
    report.add_argument("results", help="a campaign output folder (or its results.sqlite)")
    report.add_argument("--out", help="plot folder (default: RESULTS/report)")
    report.add_argument("--metrics", type=lambda text: [m for m in text.split(",") if m],
                        help="comma-separated metrics to summarise (default: all numeric)")
    report.set_defaults(handler=_cmd_report)
    listing = commands.add_parser("list", help="list bundled scenarios and campaigns")
    listing.set_defaults(handler=_cmd_list)
    return parser


def main(argv=None) -> int:
    """Entry point of the `rpod` console script."""
    logging.getLogger("drake").setLevel(logging.WARNING)
    args = make_parser().parse_args(argv)
    try:
        return args.handler(args)
    except ScenarioFileError as error:
        print(f"rpod: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("rpod: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
