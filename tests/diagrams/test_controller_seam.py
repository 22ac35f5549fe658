"""The guidance seam is real: controllers defined here, in the test, registered without editing
any rpod module, run through `rpod run` on actuation paths 2 and 3, against closed forms.

Free space (no gravity, the target fixed at the origin, L = I) makes the closed forms exact:
- path 3, a constant ideal acceleration a in L: p(t) = p0 + v0 t + a t^2 / 2, and the
  delta-v, g0 Isp ln(m0 / m), equals |a| t (the force follows the mass: f = m a);
- path 2, constant levels on the +y thrusters of rcs_cube_12 (a pure +y force): every
  thruster's impulse is level x thrust x t through the PWM, and the rocket equation gives the
  final speed exactly, v = g0 Isp ln(m0 / m), however the pulses fall.
"""

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from pydrake.systems.framework import LeafSystem

from rpod.diagrams.controller_seam import (
    Actuation,
    ControllerPlugin,
    ControllerResults,
    ControllerWiring,
    IdealCommand,
    MissionOutcome,
    controller_plugins,
    register_controller,
)
from rpod.models.config import ConfigError
from rpod.models.thrusters import STANDARD_GRAVITY_M_S2
from rpod.scenarios import cli
from rpod.systems.sensed import SENSED_SIZE

ISP_S = 220.0


class _Constant(LeafSystem):
    """A constant vector on an output port named `command` (the sensed input is read by none)."""

    def __init__(self, value):
        super().__init__()
        self.DeclareVectorInputPort("sensed", SENSED_SIZE)
        value = np.asarray(value, float)
        self.DeclareVectorOutputPort("command", len(value), lambda c, o: o.SetFromVector(value))


@dataclasses.dataclass
class ConstantAcceleration:
    """Test controller: a constant ideal acceleration in L (path 3)."""

    a_L: list[float] = dataclasses.field(default_factory=lambda: [0.0, 0.01, 0.0])
    limit_m_s2: float = 0.05
    control_period_s: float = 1.0

    def validate(self) -> None:
        if len(self.a_L) != 3:
            raise ConfigError("a_L", "expected 3 numbers")


class ConstantAccelerationPlugin(ControllerPlugin):
    config_type = ConstantAcceleration
    system_name = "constant_acceleration"
    actuation = Actuation.IDEAL

    def add_to_diagram(self, builder, scenario, sensed):
        config = scenario.controller
        system = builder.AddNamedSystem(self.system_name, _Constant(config.a_L))
        builder.Connect(sensed, system.GetInputPort("sensed"))
        return ControllerWiring(
            system,
            system.GetOutputPort("command"),
            {"commanded_acceleration_L": system.GetOutputPort("command")},
            ideal=IdealCommand("acceleration", "L", "box", config.limit_m_s2),
        )

    def results(self, scenario, wiring, context, log):
        moved = float(np.linalg.norm(log["p_LC_L"][-1] - log["p_LC_L"][0]))
        return ControllerResults(
            summary={"moved_m": moved},
            outcome=MissionOutcome(moved > 1.0, f"moved {moved:.2f} m"),
        )


@dataclasses.dataclass
class FixedLevels:
    """Test controller: constant per-thruster levels in [0, 1] (path 2)."""

    levels: list[float] = dataclasses.field(default_factory=lambda: [0.0] * 12)
    control_period_s: float = 0.1


class FixedLevelsPlugin(ControllerPlugin):
    config_type = FixedLevels
    system_name = "fixed_levels"
    actuation = Actuation.THRUSTER_COMMANDS

    def add_to_diagram(self, builder, scenario, sensed):
        config = scenario.controller
        system = builder.AddNamedSystem(self.system_name, _Constant(config.levels))
        builder.Connect(sensed, system.GetInputPort("sensed"))
        return ControllerWiring(system, system.GetOutputPort("command"))


@dataclasses.dataclass
class FixedForces:
    """Test controller: constant force vectors in C, 3 per thruster (path 2, gimbaled)."""

    forces_C: list[float] = dataclasses.field(default_factory=lambda: [0.0] * 24)
    control_period_s: float = 0.1


class FixedForcesPlugin(FixedLevelsPlugin):
    config_type = FixedForces
    system_name = "fixed_forces"

    def add_to_diagram(self, builder, scenario, sensed):
        system = builder.AddNamedSystem(self.system_name, _Constant(scenario.controller.forces_C))
        builder.Connect(sensed, system.GetInputPort("sensed"))
        return ControllerWiring(system, system.GetOutputPort("command"))


@pytest.fixture(scope="module", autouse=True)
def registered():
    for plugin in (ConstantAccelerationPlugin(), FixedLevelsPlugin(), FixedForcesPlugin()):
        register_controller(plugin)
    yield
    tags = {p.tag for p in controller_plugins()}
    assert {"ConstantAcceleration", "FixedLevels", "FixedForces"} <= tags


def _run(tmp_path, controller_yaml: str, thrusters: str = "") -> tuple[int, dict, dict]:
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(
        "orbit: {gravity: free_space}\n"
        "chaser: {p_LC_L: [0.0, -20.0, 0.0], v_LC_L: [0.0, 0.0, 0.0], mass_kg: 400.0}\n"
        "target: {w_IT_T_deg_s: [0.0, 0.0, 0.0]}\n"
        f"thrusters: {thrusters or f'{{isp_s: {ISP_S}}}'}\n"
        f"controller: {controller_yaml}\n"
        "duration_s: 20.0\nlog_period_s: 1.0\n"
    )
    out = tmp_path / "out"
    code = cli.main(["run", str(scenario), "--out", str(out), "--no-record", "--no-plots"])
    summary = json.loads((out / "summary.json").read_text())
    log = dict(np.load(out / "log.npz"))
    return code, summary, log


def test_ideal_acceleration_controller_defined_in_a_test_flies_through_rpod_run(tmp_path):
    code, summary, log = _run(tmp_path, "!ConstantAcceleration {a_L: [0.0, 0.01, 0.002]}")
    assert code == 0
    a = np.array([0.0, 0.01, 0.002])
    t = log["t"][-1]
    assert t == pytest.approx(20.0)
    # Tolerance: runge_kutta3 at accuracy 1e-6 integrates a quadratic exactly up to rounding,
    # the force steps once per control period (none: the command is constant).
    np.testing.assert_allclose(log["p_LC_L"][-1], [0.0, -20.0, 0.0] + 0.5 * a * t * t, atol=1e-6)
    assert summary["delta_v_m_s"] == pytest.approx(np.linalg.norm(a) * t, rel=1e-6)
    assert summary["moved_m"] == pytest.approx(0.5 * np.linalg.norm(a) * t * t, rel=1e-6)
    assert summary["mission"] == {
        "success": True,
        "outcome": f"moved {summary['moved_m']:.2f} m",
        "criterion": "controller",
        "controller_success": True,
        "contact": False,
    }
    assert "commanded_acceleration_L" in log


def test_ideal_path_bounds_the_command(tmp_path):
    _, summary, log = _run(
        tmp_path, "!ConstantAcceleration {a_L: [0.0, 0.2, 0.0], limit_m_s2: 0.05}"
    )
    # Box bound 0.05 m/s^2: |a_y| is clipped from 0.2.
    assert log["p_LC_L"][-1][1] == pytest.approx(-20.0 + 0.5 * 0.05 * 20.0**2, abs=1e-6)
    assert summary["delta_v_m_s"] == pytest.approx(0.05 * 20.0, rel=1e-6)


def test_per_thruster_levels_controller_flies_through_pwm_and_the_bank(tmp_path):
    from rpod.models.thrusters import rcs_cube_12, wrench_matrix

    layout = rcs_cube_12(1.5, 10.0, ISP_S)
    B = wrench_matrix(layout)  # (6, 12): [tau; f] per unit level
    levels = np.zeros(12)
    plus_y = [k for k in range(12) if B[4, k] > 0.5 * layout.max_thrusts_N[k]]
    levels[plus_y] = 0.5  # half duty on every +y thruster: a pure +y force, no torque
    assert np.allclose(B[:3] @ levels, 0.0, atol=1e-9) and np.allclose(B[3:] @ levels, [0, 10, 0])
    code, summary, log = _run(tmp_path, f"!FixedLevels {{levels: {levels.tolist()}}}")
    assert code == 0
    # Every thruster's impulse is level x thrust x t (PWM: 5 of 10 slots, exact).
    impulse = float(levels @ layout.max_thrusts_N) * 20.0
    propellant = impulse / (STANDARD_GRAVITY_M_S2 * ISP_S)
    assert summary["propellant_kg"] == pytest.approx(propellant, rel=1e-9)
    # Rocket equation along +y (one Isp, one direction): exact whatever the pulse pattern.
    speed = STANDARD_GRAVITY_M_S2 * ISP_S * math.log(400.0 / (400.0 - propellant))
    np.testing.assert_allclose(log["v_LC_L"][-1], [0.0, speed, 0.0], atol=1e-9)


def test_gimbaled_force_vectors_fly_through_the_bank_clipped_to_its_limits(tmp_path):
    """gimbaled_cuboid_8 (paper 001): thrusters 0 and 1 at half thrust along their nominal
    directions, thruster 2 commanded at 3x its limit (clipped to it, and reported). Whatever
    the chaser's rotation, the propellant is sum |f_k| t / (g0 Isp) exactly."""
    from rpod.models.thrusters import gimbaled_cuboid_8

    layout = gimbaled_cuboid_8(max_thrust_N=10.0, isp_s=ISP_S)
    forces = np.zeros((8, 3))
    forces[0] = 5.0 * layout.directions_C[0]
    forces[1] = 5.0 * layout.directions_C[1]
    forces[2] = 30.0 * layout.directions_C[2]
    code, summary, log = _run(
        tmp_path,
        f"!FixedForces {{forces_C: {forces.ravel().tolist()}}}",
        "{layout: gimbaled_cuboid_8, max_thrust_N: 10.0, isp_s: 220.0}",
    )
    assert code == 0
    propellant = (5.0 + 5.0 + 10.0) * 20.0 / (STANDARD_GRAVITY_M_S2 * ISP_S)
    assert summary["propellant_kg"] == pytest.approx(propellant, rel=1e-9)
    clipped = log["command_clipped"][-1]
    assert clipped[2] == 1.0 and clipped[0] == clipped[1] == 0.0
    np.testing.assert_allclose(log["thruster_force_C"][-1], forces.ravel())


def test_a_body_wrench_controller_on_gimbaled_thrusters_is_a_field_error(tmp_path, capsys):
    scenario = tmp_path / "bad.yaml"
    scenario.write_text("thrusters: {layout: gimbaled_cuboid_8}\ncontroller: !HoldPoint {}\n")
    assert cli.main(["run", str(scenario), "--out", str(tmp_path / "out")]) == 2
    line = capsys.readouterr().err.strip()
    assert "thrusters.layout: gimbaled_cuboid_8 takes force vectors" in line and "\n" not in line


def test_unknown_tag_is_one_line_naming_the_known_ones(tmp_path, capsys):
    scenario = tmp_path / "bad.yaml"
    scenario.write_text("controller: !NoSuchController {}\n")
    assert cli.main(["run", str(scenario), "--out", str(tmp_path / "out")]) == 2
    line = capsys.readouterr().err.strip()
    assert "\n" not in line and "controller: unknown tag !NoSuchController" in line
    assert "!HoldPoint" in line and "!ConstantAcceleration" in line


def test_campaign_figures_default_to_none(tmp_path):
    """A plug-in draws campaign figures for `rpod report` only when it says so."""
    plugin = ControllerPlugin()
    assert plugin.campaign_figures([], tmp_path) == []
    assert list(tmp_path.iterdir()) == []


@dataclasses.dataclass
class WarnedAcceleration(ConstantAcceleration):
    """ConstantAcceleration that warns at load above a 'safe' acceleration."""

    safe_m_s2: float = 0.005


class WarnedAccelerationPlugin(ConstantAccelerationPlugin):
    config_type = WarnedAcceleration

    def load_warnings(self, config, scenario):
        if float(np.max(np.abs(config.a_L))) > config.safe_m_s2:
            return [f"controller.a_L: above the safe {config.safe_m_s2} m/s^2"]
        return []


def test_load_warnings_are_said_at_load_once_and_kept_in_the_summary(tmp_path, capsys):
    register_controller(WarnedAccelerationPlugin())
    code, summary, _ = _run(tmp_path, "!WarnedAcceleration {a_L: [0.0, 0.01, 0.0]}")
    assert code == 0
    assert summary["warnings"] == ["controller.a_L: above the safe 0.005 m/s^2"]
    err = capsys.readouterr().err
    assert err.count("rpod: warning: controller.a_L: above the safe 0.005 m/s^2") == 1
    (tmp_path / "quiet").mkdir()
    _, summary, _ = _run(tmp_path / "quiet", "!WarnedAcceleration {a_L: [0.0, 0.001, 0.0]}")
    assert summary["warnings"] == []


_DEMO_SHAPES = {"demo_level": None}


class FigurePlugin(ConstantAccelerationPlugin):
    """ConstantAcceleration with a run figure of its own key, through the seam's hooks (given
    to write_plots directly, never registered)."""

    log_shapes = _DEMO_SHAPES

    def run_figures(self):
        from matplotlib.figure import Figure  # only when drawing, as the hook asks

        def draw(log, title):
            level = log.get("demo_level")
            if level is None:
                return None
            figure = Figure()
            figure.add_subplot().plot(log.t, level)
            return figure

        return {"demo_level.png": draw}


def test_a_plugins_run_figures_are_written_beside_the_generic_ones(tmp_path):
    """write_plots draws a plug-in's run_figures() on its log_shapes: a key of the wrong shape
    is not drawn (and its stale figure removed), a plug-in not given is not drawn."""
    from rpod.diagrams.plots import FIGURE_NAMES, write_plots

    plugin = FigurePlugin()
    t = np.linspace(0.0, 10.0, 11)
    log = {"t": t, "p_LC_L": np.column_stack([t, t, t]), "demo_level": np.sin(t)}
    names = [p.name for p in write_plots(log, tmp_path, plugins=[plugin])]
    assert names[-1] == "demo_level.png" and set(names[:-1]) <= set(FIGURE_NAMES)
    log["demo_level"] = np.zeros((11, 2))  # not one value per sample: skipped
    assert "demo_level.png" not in [p.name for p in write_plots(log, tmp_path, plugins=[plugin])]
    assert not (tmp_path / "demo_level.png").exists()
    log["demo_level"] = np.sin(t)
    assert "demo_level.png" not in [p.name for p in write_plots(log, tmp_path / "x", plugins=[])]


def test_loading_every_bundled_scenario_imports_no_matplotlib():
    """The built-in plug-ins import their figures only inside run_figures()/campaign_figures():
    loading a scenario (which registers them all) must not import matplotlib. In a subprocess,
    so that no other test's import counts."""
    code = (
        "import sys\n"
        "from rpod.scenarios.loader import bundled_scenarios, load_scenario\n"
        "for name in bundled_scenarios():\n"
        "    load_scenario(name)\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'matplotlib')[:5])\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    assert result.stdout.strip() == "[]", result.stdout
