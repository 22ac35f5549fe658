"""The guidance seam: how a controller plugs into rpod (DESIGN.md, "Guidance seam").

Owns: the `ControllerPlugin` interface, the registry of plug-ins (built-ins, Python entry
points of the group `rpod.controllers`, and `register_controller` calls), the three actuation
paths a controller may drive (`Actuation`), and what a plug-in hands the builder
(`ControllerWiring`) and `simulate` (`ControllerResults`).
Does not own: any controller (rpod.diagrams.controllers.* and third-party modules), the
wiring of the actuation paths (rpod.diagrams.builder) or the scenario schema
(rpod.diagrams.scenario, whose `controller` field is the union of the registered configs).

A scenario chooses its controller by YAML tag, the class name of the plug-in's config
dataclass, as Drake's typed unions do (`controller: !HoldPoint {...}`, `!SoftCapture {...}`,
or `controller: null` to coast). Each plug-in says, in one module:
- `config_type`: the config dataclass (its class name is the tag), with `validate()`;
- `validate(config, scenario)`: the checks that need the rest of the scenario;
- `add_to_diagram(builder, scenario, sensed)`: adds its systems, reads the sensed bundle
  (rpod.systems.sensed), and returns the actuation path it drives, its command port and the
  outputs to log;
- `results(...)`: its entries in summary.json and log.npz, and the mission outcome;
- `add_scene_extras(...)`: anything it draws in the Meshcat scene;
- `load_warnings(config, scenario)`: what is legal but will likely fail (a hold point the
  thrusters cannot hold), said at load by `rpod run` and kept in summary.json's `warnings`;
- optionally `make_plan(scenario, closed_loop)` -> `PlanOutput`, for `rpod plan`, and
  `campaign_table(rows)` and `campaign_figures(rows, out_dir)`, for `rpod report`;
- `run_figures()` and `log_shapes`: its own figures of a run.

Planning once at start (one pattern for every planner behind the seam). A controller that
plans before it flies plans in an initialization event of its own system
(`DeclareInitializationUnrestrictedUpdateEvent`, run by `Simulator.Initialize`), from the
sensed bundle it reads at t = 0 (the estimate under `navigation: !Ekf`, never the scenario's
truth), and keeps the plan in an abstract state of that system, never on the plug-in or the
system object: `results`, `planned_end_s` and the scene read it back through the context, and
the scene draws it from a `planned_path` output (rpod.systems.plan_at_start.PlannedPath,
drawn by rpod.systems.scene.PlannedPathOverlay). `make_plan` calls the same planning function
on `rpod.diagrams.builder.sensed_at_start(scenario)`, the bundle the truth gives at t = 0,
so `rpod plan` writes the truth-fed closed loop's first plan bit for bit. Paper 000's soft
capture (which then replans) and paper 003's planar approach (which then tracks) both do so.
"""

from __future__ import annotations

import dataclasses
import enum
import importlib.metadata
import importlib.util
import logging
import os
import pathlib
import sys
import types
import typing

ENTRY_POINT_GROUP = "rpod.controllers"
PLUGINS_VARIABLE = "RPOD_PLUGINS"


class Actuation(enum.Enum):
    """The three actuation paths (DESIGN.md): what a controller's command port carries.

    BODY_WRENCH: [tau_C; f_C] (6) -> box-constrained allocator -> PWM -> thruster bank.
    THRUSTER_COMMANDS: one level in [0, 1] per fixed thruster (n) -> PWM -> thruster bank.
    IDEAL: an ideal force or acceleration (3), bounded per axis or in norm, in L or C, applied
        straight to the truth, its propellant drawn at the thrusters' Isp; attitude torque 0.
    """

    BODY_WRENCH = "body_wrench"
    THRUSTER_COMMANDS = "thruster_commands"
    IDEAL = "ideal"


@dataclasses.dataclass(frozen=True)
class IdealCommand:
    """How the IDEAL path reads a command (3).

    Attributes:
        quantity: 'acceleration' [m/s^2] or 'force' [N].
        frame: 'L' (LVLH) or 'C' (chaser body).
        bound: 'box' (each component within +-limit, paper 004 eq. 11e) or 'norm'.
        limit: the bound, in the quantity's unit (> 0).
    """

    quantity: str = "acceleration"
    frame: str = "L"
    bound: str = "box"
    limit: float = 0.1

    def validate(self) -> None:
        """ValueError naming the bad attribute."""
        for name, allowed in (
            ("quantity", ("acceleration", "force")),
            ("frame", ("L", "C")),
            ("bound", ("box", "norm")),
        ):
            if getattr(self, name) not in allowed:
                raise ValueError(f"{name}: must be one of {allowed}, got {getattr(self, name)!r}")
        if not self.limit > 0:
            raise ValueError(f"limit: must be positive, got {self.limit}")


@dataclasses.dataclass
class ControllerWiring:
    """What a plug-in's add_to_diagram hands back to the builder.

    The path the command drives and its period are the plug-in's to say once, from the config
    (`actuation_for`, `command_period_s`), not repeated here.

    Attributes:
        system: the controller system (simulate passes its context to `results`).
        command: the command port (size 6, n or 3 by the plug-in's actuation path).
        logged: log key -> output port, logged at the scenario's log period.
        ideal: how the IDEAL path reads the command (required for Actuation.IDEAL).
        step_timer: the rpod.systems.step_timer.StepTimer wrapping the controller's control
            step, or None; with one, summary.json gives the compute per control step
            (control_steps, control_step_ms_p50, _p99, _max), the shoot-out's figure.
    """

    system: typing.Any
    command: typing.Any
    logged: dict = dataclasses.field(default_factory=dict)
    ideal: IdealCommand | None = None
    step_timer: typing.Any = None


@dataclasses.dataclass(frozen=True)
class MissionOutcome:
    """Whether the controller's mission succeeded, and the one line that says so.

    Attributes:
        success: True or False.
        text: one line for `rpod run`, e.g. "captured at 48.5 s to 0.109 m and 0.029 m/s" or
            "NOT captured: contact: the true shapes touched at t = 31.20 s".
    """

    success: bool
    text: str


@dataclasses.dataclass
class ControllerResults:
    """A plug-in's additions to a finished run.

    Attributes:
        summary: entries added to summary.json (JSON-safe).
        log: arrays added to log.npz (simulate merges them into the run's log; an entry set to
            None removes that key, e.g. a raw status vector the plug-in split into named
            arrays). Plug-ins never change the `log` they are given.
        outcome: the mission outcome, or None when the controller has no mission criterion.

    Two summary entries mean the same for every method that has a solver, and the shoot-out
    (rpod.scenarios.comparison) reads them: `solver_failures` (control steps or planner calls
    where a solution was due and no solver gave a usable one) and `fallback_s` (the time flown
    on any fallback instead of the method's nominal solution, designed fallbacks included
    [s]). A method without a solver (a PD) leaves them out.
    """

    summary: dict = dataclasses.field(default_factory=dict)
    log: dict = dataclasses.field(default_factory=dict)
    outcome: MissionOutcome | None = None


@dataclasses.dataclass
class PlanOutput:
    """A planner's result as `rpod plan` writes it, whatever the planner (a plug-in's
    `make_plan` returns one; rpod.scenarios.plan writes every one the same way).

    Attributes:
        status: the planner's status word (e.g. 'success', 'infeasible', 'check_failed').
        passed: True when the plan is usable: the planner succeeded and the independent check
            passed (`rpod plan` exits 0).
        reason: one line saying why not, or what was planned.
        arrays: name -> array, written to plan.npz (the plug-in documents them).
        summary: JSON-safe entries of summary.json, after `status`, `passed` and `reason`.
        figures: file name -> draw(arrays, title), returning a matplotlib Figure or None; import
            plotting code inside draw.
    """

    status: str
    passed: bool
    reason: str = ""
    arrays: dict = dataclasses.field(default_factory=dict)
    summary: dict = dataclasses.field(default_factory=dict)
    figures: dict = dataclasses.field(default_factory=dict)


class ControllerPlugin:
    """Base class of a controller plug-in; see the module docstring for each hook."""

    config_type: type = None  # the config dataclass; its class name is the YAML tag
    system_name: str = "controller"  # the controller system's name in the diagram
    actuation: Actuation = Actuation.BODY_WRENCH  # the path it drives (checked at load)

    @property
    def tag(self) -> str:
        """The YAML tag that selects this controller, without '!'."""
        return self.config_type.__name__

    def actuation_for(self, config) -> Actuation:
        """The path this config drives: `actuation` unless a plug-in's config chooses one."""
        return self.actuation

    def command_period_s(self, config) -> float:
        """The command's sample period [s]: the PWM period on paths 1 and 2 (each duty is held
        for it), the controller's own period on the ideal path. The default is the config's
        `control_period_s`; a plug-in whose config has none, or whose command comes at another
        period (an adapter between the law and the thrusters), overrides this. Checked at load
        (positive, finite, and bounding the run's work)."""
        period = getattr(config, "control_period_s", None)
        if period is None:
            from rpod.models.config import ConfigError

            raise ConfigError(
                "controller",
                f"!{self.tag} has no control_period_s: its plug-in must say its command's period "
                "(ControllerPlugin.command_period_s)",
            )
        return float(period)

    def validate(self, config, scenario) -> None:
        """Raises ConfigError (rpod.models.config), its field relative to the scenario.

        The default checks the bounds every numeric field declares (check_bounds, nested
        settings blocks included), then calls config.validate() when the config has one, which
        raises ConfigError with the field relative to the controller block; both are named
        `controller.<field>`. A plug-in that checks more calls this first.
        """
        from rpod.models.config import ConfigError, check_bounds

        try:
            check_bounds(config)
            check = getattr(config, "validate", None)
            if check is not None:
                check()
        except ConfigError as error:
            raise error.under("controller") from None

    def load_warnings(self, config, scenario) -> list[str]:
        """Warnings about a valid config that will likely fail its mission (one line each,
        naming the field), e.g. a hold point beyond what the thrusters can hold. `rpod run`
        prints them at load as `rpod: warning: ...`; summary.json keeps them. None by default."""
        return []

    def add_to_diagram(self, builder, scenario, sensed) -> ControllerWiring:
        """Adds the controller's systems; `sensed` is the sensed bundle's output port."""
        raise NotImplementedError

    def results(self, scenario, wiring: ControllerWiring, context, log: dict) -> ControllerResults:
        """Summary and log entries of a finished run (`context` is the diagram's root)."""
        return ControllerResults()

    def add_scene_extras(
        self, builder, meshcat, scenario, wiring: ControllerWiring, scene=None
    ) -> None:
        """Draws what the controller adds to the Meshcat scene (nothing by default).

        `scene` is the scene's RendezvousScene: geometry registered on its target frame
        (`RegisterTargetGeometry`) turns with the target in the live view and the recording.
        """

    def planned_end_s(self, wiring: ControllerWiring, context) -> float | None:
        """When the controller's own plan ends (e.g. a planned capture), read after the
        diagram's initialization events (`context` is the root); None: it has no such time.

        simulate warns when it is after duration_s, and `stop.at_plan_end` ends the run there.
        """
        return None

    def campaign_table(self, rows: list[dict]) -> tuple[str, list[str], list[list[str]]] | None:
        """A table for `rpod report` over a campaign's stored rows (title, header, rows), or
        None when the campaign is not this controller's (the default)."""
        return None

    def campaign_figures(self, rows: list[dict], out_dir) -> list:
        """Figures for `rpod report` over a campaign's stored rows, written into out_dir (a
        pathlib.Path); their paths, or [] when the campaign is not this controller's (the
        default)."""
        return []

    log_shapes: typing.ClassVar[dict] = {}
    """Log key -> its trailing shape, for the run figures' checks (rpod.diagrams.plots.RunLog):
    None (one value per sample), k (k columns) or -1 (any number of columns)."""

    def run_figures(self) -> dict:
        """The controller's own figures of a run: {file name: draw(log, title)}, where `log` is
        a rpod.diagrams.plots.RunLog and draw returns a matplotlib Figure, or None when the log
        has no data for it. `rpod run` writes them beside the generic figures. None by default.

        Import plotting code inside this method, not at module level: loading a scenario must
        not import matplotlib."""
        return {}

    make_plan = None
    """Optional: make_plan(scenario, closed_loop: bool) -> PlanOutput, the controller's plan
    from the scenario's initial state without simulating, for `rpod plan` (planned from
    `sensed_at_start`: module docstring, "Planning once at start"); `closed_loop` plans what
    the closed loop's first plan is (its tightened margins), where that differs."""


_PLUGINS: dict[str, ControllerPlugin] = {}
_DEFAULT: list[str] = []
_ENTRY_POINTS_LOADED = False


def register_controller(plugin: ControllerPlugin, *, default: bool = False) -> ControllerPlugin:
    """Makes a controller available to scenarios under the tag of its config class.

    Re-registering the same tag replaces the plug-in (a module reloaded in a notebook). The
    scenario schema reads the registry whenever it reads a scenario (config_types), so a
    plug-in registered at any time is a choice from then on.
    """
    if not dataclasses.is_dataclass(plugin.config_type):
        raise TypeError(f"{type(plugin).__name__}.config_type must be a dataclass")
    _PLUGINS[plugin.tag] = plugin
    if default:
        _DEFAULT[:] = [plugin.tag]
    return plugin


def load_entry_points() -> None:
    """Imports the plug-in modules other packages declare (entry point group rpod.controllers),
    then those the environment variable RPOD_PLUGINS names (load_plugin's forms, separated by
    os.pathsep): how campaign workers get the plug-ins `--plugin` named.

    Each entry point names a module (or an object in one) whose import registers its
    controllers. A plug-in that fails to import is logged and skipped, never fatal.
    """
    global _ENTRY_POINTS_LOADED
    if _ENTRY_POINTS_LOADED:
        return
    _ENTRY_POINTS_LOADED = True
    for entry in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        try:
            entry.load()
        except Exception as error:  # noqa: BLE001  (a broken third-party plug-in must not break rpod)
            logging.getLogger("rpod").warning("controller plug-in %s: %s", entry.name, error)
    for spec in filter(None, os.environ.get(PLUGINS_VARIABLE, "").split(os.pathsep)):
        try:
            load_plugin(spec)
        except PluginLoadError as error:
            logging.getLogger("rpod").warning("%s", error)


class PluginLoadError(Exception):
    """A plug-in module named on the command line could not be loaded (one line)."""


def load_plugin(spec: str) -> types.ModuleType:
    """Imports a plug-in module, which registers its controllers: a module name
    (`mypackage.my_controller`) or the path of a Python file (`./my_controller.py`).

    A file is imported under the module name `rpod_plugin_<stem>`, put in sys.modules so that
    its configs pickle (campaign workers) and a second load is a no-op. Raises
    PluginLoadError with one line naming the plug-in and the cause (its traceback is logged at
    debug level).
    """
    path = pathlib.Path(spec)
    try:
        if spec.endswith(".py") or path.is_file():
            if not path.is_file():
                raise PluginLoadError(f"plug-in {spec}: no such file")
            name = "rpod_plugin_" + "".join(c if c.isalnum() else "_" for c in path.stem)
            if name in sys.modules:
                return sys.modules[name]
            module_spec = importlib.util.spec_from_file_location(name, path.resolve())
            module = importlib.util.module_from_spec(module_spec)
            sys.modules[name] = module
            try:
                module_spec.loader.exec_module(module)
            except BaseException:
                del sys.modules[name]
                raise
            return module
        return importlib.import_module(spec)
    except PluginLoadError:
        raise
    except (Exception, SystemExit) as error:  # any failure of foreign code
        logging.getLogger("rpod").debug("plug-in %s", spec, exc_info=True)
        cause = " ".join(f"{type(error).__name__}: {error}".split())
        raise PluginLoadError(f"plug-in {spec}: cannot load: {cause[:200]}") from None


def remember_plugin(spec: str) -> None:
    """Adds a plug-in to RPOD_PLUGINS, so that processes started from here (campaign runners
    and local Dask workers) load it too. Files are given by absolute path."""
    if spec.endswith(".py") or pathlib.Path(spec).is_file():
        spec = str(pathlib.Path(spec).resolve())
    known = [s for s in os.environ.get(PLUGINS_VARIABLE, "").split(os.pathsep) if s]
    if spec not in known:
        os.environ[PLUGINS_VARIABLE] = os.pathsep.join([*known, spec])


def controller_plugins() -> list[ControllerPlugin]:
    """The registered plug-ins, in registration order."""
    return list(_PLUGINS.values())


def config_types() -> tuple[type, ...]:
    """The registered config types, the default first (a Union's untagged choice)."""
    tags = _DEFAULT + [tag for tag in _PLUGINS if tag not in _DEFAULT]
    return tuple(_PLUGINS[tag].config_type for tag in tags)


def default_config():
    """A config of the default controller (None when none is registered: coast)."""
    return _PLUGINS[_DEFAULT[0]].config_type() if _DEFAULT else None


def plugin_for(config) -> ControllerPlugin | None:
    """The plug-in of a controller config (None for None: no controller)."""
    if config is None:
        return None
    for plugin in _PLUGINS.values():
        if type(config) is plugin.config_type:
            return plugin
    raise KeyError(f"no controller registered for {type(config).__name__}")


def plugin_by_tag(tag: str) -> ControllerPlugin | None:
    """The plug-in registered under a tag (without '!'), or None."""
    return _PLUGINS.get(tag)
