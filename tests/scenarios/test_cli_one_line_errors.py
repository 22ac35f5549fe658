"""The one-line error everywhere (issue 8): exit 2 and exactly one stderr line naming the file and
field (or the flag), no traceback, for the YAML and command-line cases a hostile but fair user
found; and an empty scenario file runs with the defaults, as the README promises."""

import pytest
from test_cli_bad_input import assert_one_line_error, run_rpod

from rpod.diagrams.scenario import Scenario
from rpod.scenarios.campaign import parse_campaign, plan_runs
from rpod.scenarios.loader import dump_scenario, parse_scenario


def _bomb() -> str:
    lines = ["l0: &l0 [x, x, x, x, x, x, x, x, x]"]
    for level in range(1, 10):
        lines.append(f"l{level}: &l{level} [" + ", ".join([f"*l{level - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


# (case id, YAML text, what the error line must contain besides the file)
BAD_FILES = [
    ("duplicate_key", "chaser:\n  mass_kg: 400.0\n  mass_kg: 500.0\n", "duplicate key 'mass_kg'"),
    ("duplicate_top_key", "duration_s: 10.0\nduration_s: 20.0\n", "duplicate key 'duration_s'"),
    ("nested_too_deep", "chaser: " + "[" * 40 + "]" * 40 + "\n", "nested deeper"),
    ("nested_past_recursion", "chaser: " + "[" * 20000 + "]" * 20000 + "\n", "nested deeper"),
    ("alias_bomb", _bomb(), "more than"),
    (
        "both_attitudes",
        "target:\n  q_LT: [1.0, 0.0, 0.0, 0.0]\n  rpy_LT_deg: [0.0, 0.0, 10.0]\n",
        "target.q_LT",
    ),
    ("non_unit_quaternion", "target:\n  q_LT: [2.0, 0.0, 0.0, 0.0]\n", "target.q_LT"),
    ("huge_bad_value", "chaser:\n  mass_kg: '" + "x" * 100000 + "'\n", "chaser.mass_kg"),
    ("huge_bad_list", "chaser:\n  mass_kg: [" + "1.0, " * 50000 + "1.0]\n", "chaser.mass_kg"),
    ("python_tag", "chaser: !!python/object/apply:os.system ['true']\n", "constructor"),
    ("nul_byte", "duration_s: 10.0\x00\n", "not YAML text: character #x00 at line 1"),
    (
        "deep_through_aliases",  # r: *p meets p's data shallow first, q 20 levels deeper
        "p: &p " + "[" * 15 + "1" + "]" * 15 + "\nq: " + "[" * 20 + "*p" + "]" * 20 + "\nr: *p\n",
        "nested deeper",
    ),
    ("huge_integer", "chaser:\n  mass_kg: " + "9" * 4000 + "\n", "chaser.mass_kg: must be finite"),
    ("integer_past_float", "chaser:\n  mass_kg: " + "9" * 401 + "\n", "chaser.mass_kg: must be"),
    ("integer_too_long", "chaser:\n  mass_kg: " + "9" * 5000 + "\n", "integer too long"),
]


@pytest.mark.parametrize("case, text, phrase", BAD_FILES, ids=[c[0] for c in BAD_FILES])
def test_bad_yaml_is_one_short_line(tmp_path, case, text, phrase):
    scenario = tmp_path / f"{case}.yaml"
    scenario.write_text(text)
    out = tmp_path / "out"
    process = run_rpod("run", str(scenario), "--out", str(out), "--no-record", cwd=tmp_path)
    assert_one_line_error(process, str(scenario), phrase)
    assert len(process.stderr) < 400  # quoted values are cut, never the whole value
    assert not out.exists()


# (case id, command line, what the error line must contain)
BAD_COMMAND_LINES = [
    ("no_command", [], "required"),
    ("unknown_command", ["fly"], "invalid choice"),
    ("unknown_flag", ["run", "hold_point", "--bogus"], "--bogus"),
    ("extra_argument", ["run", "hold_point", "extra"], "extra"),
    ("sweep_without_campaign", ["sweep"], "campaign"),
    ("bad_workers", ["sweep", "demo_sweep", "--workers", "many"], "--workers"),
    ("bad_timeout", ["sweep", "demo_sweep", "--timeout-s", "-3"], "--timeout-s"),
]


@pytest.mark.parametrize(
    "case, argv, phrase", BAD_COMMAND_LINES, ids=[c[0] for c in BAD_COMMAND_LINES]
)
def test_command_line_errors_are_one_line_with_the_help_hint(tmp_path, case, argv, phrase):
    process = run_rpod(*argv, cwd=tmp_path)
    assert_one_line_error(process, phrase, "--help")
    assert "usage:" not in process.stderr
    assert list(tmp_path.iterdir()) == []


def test_empty_and_comment_only_files_mean_every_default():
    # Compared as YAML: Drake's SimulatorConfig (a bound C++ type) has no value equality.
    defaults = dump_scenario(Scenario())
    assert dump_scenario(parse_scenario("", "empty.yaml")) == defaults
    assert dump_scenario(parse_scenario("# nothing here\n\n", "comments.yaml")) == defaults


def test_campaign_with_an_empty_base_file_plans(tmp_path):
    (tmp_path / "empty.yaml").write_text("# every default\n")
    text = "base: empty.yaml\ngrid:\n  chaser.mass_kg: [400.0, 500.0]\n"
    runs = plan_runs(parse_campaign(text, "c.yaml", "c", tmp_path))
    assert [r.overrides for r in runs] == [{"chaser.mass_kg": 400.0}, {"chaser.mass_kg": 500.0}]


@pytest.mark.slow
def test_empty_scenario_file_runs_with_the_defaults(tmp_path):
    """The README's promise, through the command line: no TypeError traceback, a real run.

    Slow (600 s of flight): by default its parts are held by faster tests. An empty file reads
    as every default (test_empty_and_comment_only_files_mean_every_default; `rpod run FILE`
    reads a file through that same parse_scenario), and the default flight differs from the
    bundled hold_point only in its description, duration (600 s against 300 s), log period and
    RAAN, and the bundled run through the console entry point exits 0 and writes every output
    (test_run_hold_point.py)."""
    scenario = tmp_path / "empty.yaml"
    scenario.write_text("")
    # Every default: 600 s of the default approach, ~10 s of wall time.
    process = run_rpod("run", str(scenario), "--out", str(tmp_path / "out"), "--no-record",
                       cwd=tmp_path)  # fmt: skip
    assert process.returncode == 0, process.stderr
    assert (tmp_path / "out" / "summary.json").is_file()


def test_a_closed_pipe_is_not_a_traceback(tmp_path):
    """`rpod list | head -0`: the reader is gone before rpod writes; rpod exits quietly."""
    import subprocess
    import sys

    process = subprocess.Popen(
        [sys.executable, "-m", "rpod.scenarios.cli", "list"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    process.stdout.close()  # no reader: every write fails with EPIPE
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 0, stderr
    assert b"Traceback" not in stderr and b"BrokenPipeError" not in stderr
