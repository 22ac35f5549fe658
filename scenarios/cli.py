"""The `rpod` command line: `rpod run SCENARIO`, `rpod list`.

Exit status: 0 on success; 1 when a simulation ran but failed (its outputs are written and its
summary says why); 2 on a bad command line, file or field, with one line on stderr naming the
file and field and no traceback.
"""

import argparse
import logging
import pathlib
import sys

from rpod.scenarios.loader import ScenarioFileError, bundled_scenarios, load_scenario

EXIT_BAD_INPUT = 2


def _description(path: pathlib.Path) -> str:
    """The `description:` of a scenario file, read without building the scenario."""
    import yaml

    try:
        return str((yaml.safe_load(path.read_text()) or {}).get("description", ""))
    except (OSError, yaml.YAMLError, AttributeError):
        return "(unreadable)"


def _cmd_list(args) -> int:
    scenarios = bundled_scenarios()
    width = max(len(name) for name in scenarios)
    print("Scenarios (rpod run NAME):")
    for name, path in scenarios.items():
        print(f"  {name:<{width}}  {_description(path)}")
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
    run.add_argument("scenario", help="a scenario file or the name of a bundled scenario")
    run.add_argument("--out", help="output folder (default: runs/<scenario>)")
    run.add_argument("--no-record", action="store_true", help="skip the Meshcat recording")
    run.set_defaults(handler=_cmd_run)
    listing = commands.add_parser("list", help="list bundled scenarios")
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
