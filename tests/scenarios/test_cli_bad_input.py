"""Bad input: exit status 2, one line naming the file and field, no traceback, no output left.

Each case runs the command line's `main` in this process (`run_rpod_in_process`: the exit
status, stdout and stderr a user sees, without ~1.3 s of imports per case) with --out pointing
into tmp_path; after the failure nothing may exist there. One case also runs the real console
entry point in a subprocess, so the two are known to agree.
"""

import subprocess

import pytest
from campaign_helpers import rpod_command, run_rpod_in_process

GOOD_INERTIA = "[[100.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 100.0]]"

# (case id, YAML text, the field the error line must name)
BAD_FILES = [
    ("syntax_error", "chaser: [1, 2\n", "YAML syntax error"),
    ("unknown_field", "chaser:\n  massx_kg: 3.0\n", "chaser.massx_kg"),
    ("unknown_top_level", "durationn_s: 3.0\n", "durationn_s"),
    ("wrong_type", "chaser:\n  mass_kg: heavy\n", "chaser.mass_kg"),
    ("wrong_type_in_list", "chaser:\n  p_LC_L: [1.0, x, 3.0]\n", "chaser.p_LC_L[1]"),
    ("negative_mass", "chaser:\n  mass_kg: -500.0\n", "chaser.mass_kg"),
    ("negative_thrust", "thrusters:\n  max_thrust_N: -10.0\n", "thrusters.max_thrust_N"),
    ("zero_isp", "thrusters:\n  isp_s: 0.0\n", "thrusters.isp_s"),
    (
        "inertia_not_symmetric",
        "target:\n  inertia_kg_m2: [[100.0, 5.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 100.0]]\n",
        "target.inertia_kg_m2",
    ),
    (
        "inertia_not_positive_definite",
        "chaser:\n  inertia_kg_m2: [[100.0, 0.0, 0.0], [0.0, -100.0, 0.0], [0.0, 0.0, 100.0]]\n",
        "chaser.inertia_kg_m2",
    ),
    (
        "inertia_triangle_inequality",
        "target:\n  inertia_kg_m2: [[100.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 300.0]]\n",
        "target.inertia_kg_m2",
    ),
    ("quaternion_zero_norm", "target:\n  q_LT: [0.0, 0.0, 0.0, 0.0]\n", "target.q_LT"),
    ("altitude_below_100_km", "orbit:\n  altitude_m: 99000.0\n", "orbit.altitude_m"),
    (
        "cone_angle_zero",
        "target:\n  corridor_half_angle_deg: 0.0\n",
        "target.corridor_half_angle_deg",
    ),
    (
        "cone_angle_90",
        "target:\n  corridor_half_angle_deg: 90.0\n",
        "target.corridor_half_angle_deg",
    ),
    ("unknown_gravity", "orbit:\n  gravity: moon\n", "orbit.gravity"),
    ("epoch_not_a_date", "orbit:\n  epoch_utc: '2000-13-01T00:00:00'\n", "orbit.epoch_utc"),
    ("vector_length", "chaser:\n  v_LC_L: [0.0, 0.0]\n", "chaser.v_LC_L"),
    ("top_level_not_mapping", "- 1\n- 2\n", "(top level)"),
]


def run_rpod(*args, cwd):
    """`rpod ARGS` in this process: the completed process's exit status, stdout and stderr."""
    return run_rpod_in_process(*args, cwd=cwd, timeout=120)


def assert_one_line_error(process, *must_contain):
    assert process.returncode == 2, process.stderr
    lines = process.stderr.strip().splitlines()
    assert len(lines) == 1, process.stderr  # one line, so no traceback
    assert "Traceback" not in process.stderr
    for text in must_contain:
        assert text in lines[0], lines[0]


@pytest.mark.parametrize("case, text, field", BAD_FILES, ids=[c[0] for c in BAD_FILES])
def test_bad_scenario_file_exits_2_naming_file_and_field(tmp_path, case, text, field):
    scenario = tmp_path / f"{case}.yaml"
    scenario.write_text(text)
    out = tmp_path / "out"
    process = run_rpod("run", str(scenario), "--out", str(out), "--no-record", cwd=tmp_path)
    assert_one_line_error(process, str(scenario), field)
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [scenario.name]  # nothing else left


def test_the_console_entry_point_says_the_same_line_in_a_subprocess(tmp_path):
    case, text, field = BAD_FILES[0]
    scenario = tmp_path / f"{case}.yaml"
    scenario.write_text(text)
    argv = ("run", str(scenario), "--out", str(tmp_path / "out"), "--no-record")
    process = subprocess.run(
        rpod_command(*argv), cwd=tmp_path, capture_output=True, text=True, timeout=120, check=False
    )
    assert_one_line_error(process, str(scenario), field)
    assert process.stderr == run_rpod(*argv, cwd=tmp_path).stderr


def test_missing_file_exits_2(tmp_path):
    missing = tmp_path / "nope.yaml"
    process = run_rpod("run", str(missing), "--no-record", cwd=tmp_path)
    assert_one_line_error(process, str(missing), "no such file")
    assert list(tmp_path.iterdir()) == []


def test_unknown_bundled_name_exits_2(tmp_path):
    process = run_rpod("run", "no_such_scenario", cwd=tmp_path)
    assert_one_line_error(process, "no_such_scenario", "hold_point")
    assert list(tmp_path.iterdir()) == []


def test_bad_command_line_exits_2(tmp_path):
    process = run_rpod("fly", cwd=tmp_path)
    assert process.returncode == 2


def test_list_shows_bundled_scenarios_with_descriptions(tmp_path):
    process = run_rpod("list", cwd=tmp_path)
    assert process.returncode == 0, process.stderr
    lines = {line.split()[0]: line for line in process.stdout.splitlines()[1:]}
    assert {"hold_point", "coast"} <= set(lines)
    assert all(len(line.split()) > 2 for line in lines.values())  # each has a description


def test_every_bundled_scenario_loads(tmp_path):
    from rpod.scenarios.loader import bundled_scenarios, load_scenario

    for name in bundled_scenarios():
        loaded_name, scenario = load_scenario(name)
        assert loaded_name == name and scenario.description


def test_good_file_with_only_some_fields_gets_defaults():
    from rpod.diagrams.scenario import Scenario
    from rpod.scenarios.loader import parse_scenario

    scenario = parse_scenario(f"chaser:\n  mass_kg: 250\n  inertia_kg_m2: {GOOD_INERTIA}\n")
    assert scenario.chaser.mass_kg == 250.0
    assert scenario.target == Scenario().target


def test_run_without_a_scenario_runs_the_default(tmp_path, monkeypatch):
    """`rpod run` with no argument means `rpod run hold_point` (parsed, not simulated here)."""
    from rpod.scenarios.cli import DEFAULT_SCENARIO, make_parser

    args = make_parser().parse_args(["run"])
    assert args.scenario == DEFAULT_SCENARIO == "hold_point"


def test_plan_of_a_scenario_without_a_planner_exits_2(tmp_path):
    process = run_rpod("plan", "hold_point", "--out", str(tmp_path / "out"), cwd=tmp_path)
    assert_one_line_error(process, "hold_point")
    assert list(tmp_path.iterdir()) == []
