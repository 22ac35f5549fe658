"""Speed of the truth and of the bundled scenarios: real-time factors, a plain-numpy reference,
and where the wall time of a step goes.

    python benchmarks/bench_hold_point.py [--repeat N]

Prints the tables and writes them to benchmarks/results/hold_point.md. Every figure is measured
in this run, and ratios are to references measured in the same run:

1. Real-time factors of the bundled scenarios and of variants of hold_point (no recording),
   each run with the one-system truth (`Truth`, what rpod builds) and with the four systems it
   replaced (`SplitTruth`: `OrbitalDynamics`, two `RigidBodyAttitude`, `ThrusterBank`, put in
   the same diagram through `rpod.diagrams.builder.Truth`; test-only code in tests/reference,
   imported with the repository root put on sys.path). The two runs of a case alternate,
   so load on a shared machine hits both alike; best of N each.
2. A plain-numpy reference for the goal case (hold_point, PWM 10 Hz x 10 slots, two_body_j2):
   the same 27 equations as a plain Python function, integrated with Drake's RK3 tableau over
   the step sequence the Drake run took, with the thrust each step had (both recorded from a
   Drake run, then replayed). It has no controller, allocator, PWM, logger or framework: it is
   the cost floor of Python for this integration. The final states must agree to round-off.
3. The wall time of the goal case broken down by system: every Python callback of the diagram's
   systems is timed (exclusive of the callbacks it calls); the rest is Drake's C++ (integrator,
   events, caching, the C++ loggers and multiplexer) and the Python/C++ transitions.
4. The cost of one truth derivative: the plain Python function, `Truth` and `SplitTruth`.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import logging
import math
import os
import pathlib
import sys
import time
from collections import defaultdict

import numpy as np
from machine import machine_line  # benchmarks/machine.py, beside this script
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator

import rpod.diagrams.builder as builder_module
from rpod.diagrams.builder import build_diagram
from rpod.diagrams.simulate import simulate
from rpod.models.gravity import J2_EARTH, MU_EARTH_M3_S2, R_EARTH_M
from rpod.scenarios.loader import load_scenario
from rpod.systems.truth import Truth

# SplitTruth is test-only (tests/reference, not part of the rpod package): reach it from the root.
sys.path.append(str(pathlib.Path(__file__).resolve().parents[1]))
from tests.reference.split_truth import SplitTruth

GOAL_REAL_TIME_FACTOR = 100.0
RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "hold_point.md"
COMMAND = "python benchmarks/bench_hold_point.py"
SHARED_LOAD = 1.5  # 1-minute load above this on the machine: other work shares its cores


def replace(scenario, **changes):
    """A copy of scenario with dotted-path fields changed ('thrusters.pwm': False)."""
    for path, value in changes.items():
        head, _, rest = path.partition(".")
        if rest:
            scenario = dataclasses.replace(
                scenario, **{head: replace(getattr(scenario, head), **{rest: value})}
            )
        else:
            scenario = dataclasses.replace(scenario, **{head: value})
    return scenario


@contextlib.contextmanager
def truth_class(cls):
    """build_diagram builds its truth from `cls` (Truth or SplitTruth) inside the block."""
    saved = builder_module.Truth
    builder_module.Truth = cls
    try:
        yield
    finally:
        builder_module.Truth = saved


def time_call(function, count: int) -> float:
    """Best of 5 batches: mean seconds per call."""
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(count):
            function()
        best = min(best, (time.perf_counter() - start) / count)
    return best


# ---- 1. Real-time factors, before (four systems) and after (one), paired. ----


def cases():
    """(name, scenario) of every row of table 1."""
    _, hold = load_scenario("hold_point")
    _, coast = load_scenario("coast")
    _, soft = load_scenario("soft_capture")
    return [
        ("hold_point: PWM 10 Hz x 10 slots, two_body_j2 (the goal case)", hold),
        ("hold_point without PWM (duty as throttle)", replace(hold, **{"thrusters.pwm": False})),
        ("hold_point, PWM, two_body (no J2)", replace(hold, **{"orbit.gravity": "two_body"})),
        ("hold_point, PWM, 5 slots per period", replace(hold, **{"thrusters.subdivisions": 5})),
        ("soft_capture (bundled, closed loop with planning)", soft),
        ("coast: 3000 s, runge_kutta5, no thrusters", coast),
    ]


def real_time_factors(repeat: int) -> list[dict]:
    """Per case: the best summaries with Truth and SplitTruth, and the median paired ratio."""
    rows = []
    for name, scenario in cases():
        runs = {"Truth": [], "SplitTruth": []}
        for r in range(repeat):
            order = (Truth, SplitTruth) if r % 2 == 0 else (SplitTruth, Truth)
            for cls in order:
                with truth_class(cls):
                    runs[cls.__name__].append(simulate(scenario).summary)
        best = {key: max(s, key=lambda s: s["real_time_factor"]) for key, s in runs.items()}
        ratios = [
            a["real_time_factor"] / b["real_time_factor"]
            for a, b in zip(runs["Truth"], runs["SplitTruth"])
        ]
        rows.append(
            {
                "name": name,
                "after": best["Truth"],
                "before": best["SplitTruth"],
                "speedup": float(np.median(ratios)),
            }
        )
        print(
            f"  {name}: {best['Truth']['real_time_factor']:.1f}x (before "
            f"{best['SplitTruth']['real_time_factor']:.1f}x)",
            file=sys.stderr,
            flush=True,
        )
    return rows


# ---- 2. The plain-numpy reference: same equations, same steps, same pulses. ----


def plain_rhs(x, thrust, gravity, J_T, J_T_inv, J_C, J_C_inv):
    """The truth's 27 derivatives as one plain Python function (two_body / two_body_j2).

    State as rpod.systems.truth: [p_IT_I, v_IT_I, p_TC_I, v_TC_I, m_C, q_IT, w_IT_T, q_IC,
    w_IC_C]; thrust = (tau_C, f_C, mdot). Written out here from the equations (gravity, J2,
    Rodrigues rotation, Euler's equations, quaternion kinematics) with no rpod function.
    """
    px, py, pz, vx, vy, vz, rx, ry, rz, sx, sy, sz, m = x[0:13]
    tw, tx, ty, tz, wtx, wty, wtz = x[13:20]
    cw, cx, cy, cz, wcx, wcy, wcz = x[20:27]
    taux, tauy, tauz, fx, fy, fz, mdot = thrust

    def g(x, y, z):  # -mu r / r^3 + J2 (Vallado eq. 8-30)
        r2 = x * x + y * y + z * z
        r = math.sqrt(r2)
        k0 = -MU_EARTH_M3_S2 / (r2 * r)
        if gravity != "two_body_j2":
            return k0 * x, k0 * y, k0 * z
        k = -1.5 * J2_EARTH * MU_EARTH_M3_S2 * R_EARTH_M * R_EARTH_M / (r2 * r2 * r)
        s = 5.0 * z * z / r2
        return (k0 + k * (1.0 - s)) * x, (k0 + k * (1.0 - s)) * y, (k0 + k * (3.0 - s)) * z

    aT = g(px, py, pz)
    aC = g(px + rx, py + ry, pz + rz)
    n = 1.0 / math.sqrt(cw * cw + cx * cx + cy * cy + cz * cz)
    w, qx, qy, qz = cw * n, cx * n, cy * n, cz * n
    ux, uy, uz = 2.0 * (qy * fz - qz * fy), 2.0 * (qz * fx - qx * fz), 2.0 * (qx * fy - qy * fx)
    fIx = fx + w * ux + (qy * uz - qz * uy)
    fIy = fy + w * uy + (qz * ux - qx * uz)
    fIz = fz + w * uz + (qx * uy - qy * ux)
    im = 1.0 / m
    J, Ji = J_T, J_T_inv
    hx = J[0] * wtx + J[1] * wty + J[2] * wtz
    hy = J[3] * wtx + J[4] * wty + J[5] * wtz
    hz = J[6] * wtx + J[7] * wty + J[8] * wtz
    ex, ey, ez = hy * wtz - hz * wty, hz * wtx - hx * wtz, hx * wty - hy * wtx
    J, Jc = J_C, J_C_inv
    hx = J[0] * wcx + J[1] * wcy + J[2] * wcz
    hy = J[3] * wcx + J[4] * wcy + J[5] * wcz
    hz = J[6] * wcx + J[7] * wcy + J[8] * wcz
    gx, gy, gz = hy * wcz - hz * wcy + taux, hz * wcx - hx * wcz + tauy, hx * wcy - hy * wcx + tauz
    return [
        vx,
        vy,
        vz,
        aT[0],
        aT[1],
        aT[2],
        sx,
        sy,
        sz,
        aC[0] - aT[0] + fIx * im,
        aC[1] - aT[1] + fIy * im,
        aC[2] - aT[2] + fIz * im,
        -mdot,
        0.5 * (-tx * wtx - ty * wty - tz * wtz),
        0.5 * (tw * wtx + ty * wtz - tz * wty),
        0.5 * (tw * wty + tz * wtx - tx * wtz),
        0.5 * (tw * wtz + tx * wty - ty * wtx),
        Ji[0] * ex + Ji[1] * ey + Ji[2] * ez,
        Ji[3] * ex + Ji[4] * ey + Ji[5] * ez,
        Ji[6] * ex + Ji[7] * ey + Ji[8] * ez,
        0.5 * (-cx * wcx - cy * wcy - cz * wcz),
        0.5 * (cw * wcx + cy * wcz - cz * wcy),
        0.5 * (cw * wcy + cz * wcx - cx * wcz),
        0.5 * (cw * wcz + cx * wcy - cy * wcx),
        Jc[0] * gx + Jc[1] * gy + Jc[2] * gz,
        Jc[3] * gx + Jc[4] * gy + Jc[5] * gz,
        Jc[6] * gx + Jc[7] * gy + Jc[8] * gz,
    ]


def inertias(scenario):
    """(J_T, J_T^-1, J_C, J_C^-1) as flat float lists."""
    J_T = np.asarray(scenario.target.inertia_kg_m2, float)
    J_C = np.asarray(scenario.chaser.inertia_kg_m2, float)
    return [J.ravel().tolist() for J in (J_T, np.linalg.inv(J_T), J_C, np.linalg.inv(J_C))]


def make_simulator(diagram, scenario) -> Simulator:
    """A Simulator configured as rpod.diagrams.simulate.simulate configures it."""
    simulator = Simulator(diagram)
    ApplySimulatorConfig(scenario.simulator, simulator)
    return simulator


def record_steps(scenario):
    """(x0, [(h, thrust)], final x) of a Drake run: every step's size and the thrust it had.

    The monitor runs after each step, before the events at its end, so the truth's thrust cache
    then still holds the pulse pattern the step was integrated with.
    """
    diagram, handles = build_diagram(scenario)
    truth = handles.orbital
    simulator = make_simulator(diagram, scenario)
    context = simulator.get_mutable_context()
    truth_context = truth.GetMyContextFromRoot(context)
    times, thrusts = [], []

    def monitor(root_context):
        times.append(root_context.get_time())
        thrusts.append(truth.thrust(truth_context))

    x0 = truth_context.get_continuous_state_vector().CopyToVector()
    simulator.set_monitor(monitor)
    simulator.Initialize()
    simulator.AdvanceTo(scenario.duration_s)
    x_end = truth_context.get_continuous_state_vector().CopyToVector()
    # The monitor's first call is at Initialize (t = 0); each later one ends a step.
    steps = [(t1 - t0, thrust) for t0, t1, thrust in zip(times, times[1:], thrusts[1:])]
    return x0, steps, x_end, simulator.get_integrator().get_num_steps_taken()


def replay_rk3(x0, steps, gravity, J):
    """Drake's RK3 (runge_kutta3_integrator.cc) over the recorded steps, in numpy:
    k1 = f(x0), k2 = f(x0 + h/2 k1), k3 = f(x0 - h k1 + 2 h k2), x1 = x0 + h/6 (k1 + 4 k2 + k3)."""
    x = np.array(x0)
    for h, thrust in steps:
        k1 = np.array(plain_rhs(x.tolist(), thrust, gravity, *J))
        k2 = np.array(plain_rhs((x + 0.5 * h * k1).tolist(), thrust, gravity, *J))
        k3 = np.array(plain_rhs((x + h * (2.0 * k2 - k1)).tolist(), thrust, gravity, *J))
        x = x + (h / 6.0) * (k1 + 4.0 * k2 + k3)
    return x


def plain_reference(scenario, repeat: int) -> dict:
    """Records a Drake run's steps and thrusts, replays them `repeat` times; best wall time and
    the difference between the two final states."""
    x0, steps, x_end, drake_steps = record_steps(scenario)
    J = inertias(scenario)
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        x = replay_rk3(x0, steps, scenario.orbit.gravity, J)
        best = min(best, time.perf_counter() - start)
    return {
        "wall_s": best,
        "sim_s": scenario.duration_s,
        "steps": len(steps),
        "drake_steps": drake_steps,
        "position_difference_m": float(np.linalg.norm(x[6:9] - x_end[6:9])),
        "velocity_difference_m_s": float(np.linalg.norm(x[9:12] - x_end[9:12])),
        "mass_difference_kg": float(abs(x[12] - x_end[12])),
        "propellant_kg": float(x0[12] - x_end[12]),
    }


# ---- 3. Where the wall time goes: every Python callback timed by system. ----

_totals = defaultdict(float)
_counts = defaultdict(int)
_stack = []


def _timed(key, function):
    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        _stack.append(0.0)
        start = time.perf_counter()
        try:
            return function(*args, **kwargs)
        finally:
            elapsed = time.perf_counter() - start
            children = _stack.pop()
            _totals[key] += elapsed - children  # exclusive of the callbacks it called
            _counts[key] += 1
            if _stack:
                _stack[-1] += elapsed

    return wrapper


@contextlib.contextmanager
def timed_callbacks(classes):
    """Times every method of `classes` that Drake may call (callbacks are bound at
    construction, so build the diagram inside the block)."""
    saved = []
    for cls in classes:
        for name, function in list(vars(cls).items()):
            callback = name.startswith("Do") or (name.startswith("_") and not name.startswith("__"))
            if callback and callable(function) and not isinstance(function, (type, staticmethod)):
                saved.append((cls, name, function))
                setattr(cls, name, _timed((cls.__name__, name), function))
    try:
        yield
    finally:
        for cls, name, function in saved:
            setattr(cls, name, function)


def breakdown(scenario, plain_summary) -> dict:
    """Per-callback exclusive times of one instrumented goal-case run."""
    diagram, _ = build_diagram(scenario)
    classes = {type(system) for system in diagram.GetSystems()}
    classes = [c for c in classes if c.__module__.startswith("rpod.")]
    _totals.clear()
    _counts.clear()
    with timed_callbacks(classes):
        summary = simulate(scenario).summary
    return {
        "summary": summary,
        "plain": plain_summary,
        "totals": dict(_totals),
        "counts": dict(_counts),
    }


def _group(cls_name, method):
    if cls_name == "Truth":
        if method == "DoCalcTimeDerivatives":
            return "Truth: derivative (3 per step)"
        if method == "_calc_thrust":
            return "Truth: thrust of a new command (once per PWM slot)"
        return "Truth: outputs (controller, monitor, loggers)"
    if cls_name == "PwmModulator":
        return "PwmModulator: slot update and thruster_on (once per slot)"
    return f"{cls_name}"


# ---- 4. One derivative. ----


def derivative_costs(scenario) -> list[tuple]:
    """(name, us per call, ratio to the plain function) of one truth derivative.

    As in an integrator stage, the state changes before every evaluation (so no output cached
    inside SplitTruth, such as the chaser attitude its orbit reads, is reused); the cost of that
    state write, timed alone, is subtracted. The thruster command is fixed (its thrust is
    cached, as between two PWM slots).
    """
    J = inertias(scenario)
    drake_rows = []
    x0 = thrust = None
    for cls in (Truth, SplitTruth):
        with truth_class(cls):
            truth = build_diagram(scenario)[1].orbital
        context = truth.CreateDefaultContext()
        truth.GetInputPort("thruster_command").FixValue(context, np.r_[1.0, 0.0, 1.0, np.zeros(9)])
        derivatives = truth.AllocateTimeDerivatives()
        state = context.get_mutable_continuous_state_vector()
        base = state.CopyToVector()
        states = [base * (1.0 + 1e-12 * k) for k in range(16)]
        if cls is Truth:
            x0, thrust = base.tolist(), truth.thrust(context)
        counter = [0]

        def write(state=state, states=states, counter=counter):
            counter[0] += 1
            state.SetFromVector(states[counter[0] & 15])

        def write_and_evaluate(truth=truth, context=context, derivatives=derivatives, write=write):
            write()
            truth.CalcTimeDerivatives(context, derivatives)

        seconds = time_call(write_and_evaluate, 3000) - time_call(write, 3000)
        drake_rows.append((f"{cls.__name__}.CalcTimeDerivatives (Drake)", seconds))
    gravity = scenario.orbit.gravity
    reference = time_call(lambda: plain_rhs(x0, thrust, gravity, *J), 3000)
    rows = [("plain Python function, same equations (reference)", reference)] + drake_rows
    return [(name, 1e6 * seconds, seconds / reference) for name, seconds in rows]


# ---- Report. ----


def _rate_row(name, summary, reference_rtf) -> str:
    """One row of table 2: a Drake run beside the plain reference."""
    per_step = 1e6 * summary["wall_time_s"] / summary["integrator_steps"]
    return (
        f"| {name} | {summary['sim_time_s']:.0f} | {summary['integrator_steps']} "
        f"| {summary['wall_time_s']:.2f} | {summary['real_time_factor']:.1f} | {per_step:.0f} "
        f"| {reference_rtf / summary['real_time_factor']:.2f} |"
    )


def report(args, rtf_rows, reference, parts, derivatives, load_start, load_end, elapsed) -> str:
    """The markdown of benchmarks/results/hold_point.md."""
    goal, before = rtf_rows[0]["after"], rtf_rows[0]["before"]
    loads = (
        f"1/5/15-minute load average {load_start[0]:.2f}/{load_start[1]:.2f}/"
        f"{load_start[2]:.2f} at the start and {load_end[0]:.2f}/{load_end[1]:.2f}/"
        f"{load_end[2]:.2f} at the end, on {os.cpu_count()} cores"
    )
    if max(load_start[0], load_end[0]) > SHARED_LOAD:
        load_line = (
            f"The machine was shared with other work ({loads}); absolute wall times carry that "
            "noise, the paired ratios less so."
        )
    else:
        load_line = f"Load: {loads}."
    lines = [
        "# hold_point benchmark",
        "",
        f"Machine: {machine_line()}.",
        f"Command: `{COMMAND} --repeat {args.repeat}` ({elapsed:.0f} s).",
        load_line,
        "",
        "## 1. Real-time factor, one-system truth (now) and four-system truth (before)",
        "",
        (
            "`Truth`: the one-system truth the builder uses. `SplitTruth`: `OrbitalDynamics`, two "
            "`RigidBodyAttitude` and `ThrusterBank` wired as the builder wired them before, in "
            f"the same diagram otherwise. Best of {args.repeat} runs each, the two alternating; "
            "speed-up: the median of the paired (back-to-back) ratios. Goal: 100x for the goal "
            "case."
        ),
        "",
        (
            "| case | sim s | RTF now | RTF before | speed-up | share of goal (now) | steps "
            "| derivatives | wall per step now (us) | before (us) |"
        ),
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in rtf_rows:
        a, b = row["after"], row["before"]
        lines.append(
            f"| {row['name']} | {a['sim_time_s']:.0f} | {a['real_time_factor']:.1f} "
            f"| {b['real_time_factor']:.1f} | {row['speedup']:.2f} "
            f"| {a['real_time_factor'] / GOAL_REAL_TIME_FACTOR:.2f} | {a['integrator_steps']} "
            f"| {a['derivative_evaluations']} "
            f"| {1e6 * a['wall_time_s'] / a['integrator_steps']:.0f} "
            f"| {1e6 * b['wall_time_s'] / b['integrator_steps']:.0f} |"
        )
    ref_rtf = reference["sim_s"] / reference["wall_s"]
    lines += [
        "",
        "## 2. Goal case against a plain-numpy reference (same equations, steps and pulses)",
        "",
        (
            "The reference integrates `plain_rhs` (the 27 truth equations written out in this "
            "file) with Drake's RK3 tableau over the step sizes the Drake run took, each with the "
            "thrust it had, recorded from a Drake run and replayed. No controller, allocator, "
            f"PWM or logger: the Python floor of this integration. Best of {args.repeat}."
        ),
        "",
        (
            "| run | sim s | steps | wall s | real-time factor | wall per step (us) "
            "| cost ratio to the reference |"
        ),
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: |",
        (
            f"| plain-numpy reference | {reference['sim_s']:.0f} | {reference['steps']} "
            f"| {reference['wall_s']:.2f} | {ref_rtf:.1f} "
            f"| {1e6 * reference['wall_s'] / reference['steps']:.0f} | 1.00 |"
        ),
        _rate_row("Drake diagram, `Truth` (now, everything)", goal, ref_rtf),
        _rate_row("Drake diagram, `SplitTruth` (before, everything)", before, ref_rtf),
        "",
        (
            "Same integration: the replay's final state differs from Drake's by "
            f"{reference['position_difference_m']:.1e} m in relative position, "
            f"{reference['velocity_difference_m_s']:.1e} m/s in relative velocity and "
            f"{reference['mass_difference_kg']:.1e} kg in mass "
            f"({reference['propellant_kg']:.4f} kg burnt), over {reference['steps']} steps "
            f"(Drake took {reference['drake_steps']})."
        ),
    ]
    summary, plain = parts["summary"], parts["plain"]
    sim_s, wall_s = summary["sim_time_s"], summary["wall_time_s"]
    steps_per_s = summary["integrator_steps"] / sim_s
    groups = defaultdict(lambda: [0.0, 0])
    for (cls_name, method), seconds in parts["totals"].items():
        group = groups[_group(cls_name, method)]
        group[0] += seconds
        group[1] += parts["counts"][(cls_name, method)]
    python_s = sum(seconds for seconds, _ in groups.values())
    lines += [
        "",
        "## 3. Goal case: wall time by system",
        "",
        (
            "One run with every Python callback of the diagram's systems timed (exclusive of "
            "the callbacks it calls). Timing costs ~0.3 us a call: this run took "
            f"{1e3 * wall_s / sim_s:.2f} ms per simulated second, the plain one "
            f"{1e3 * plain['wall_time_s'] / plain['sim_time_s']:.2f}; "
            f"{steps_per_s:.1f} steps per simulated second."
        ),
        "",
        "| part | calls per sim s | us per call | ms per sim s | us per step | share |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    rest = (
        "Drake C++ and Python/C++ transitions (the rest: integrator, events, caches, "
        "C++ loggers and multiplexer)"
    )
    ordered = sorted(groups.items(), key=lambda item: -item[1][0])
    ordered.append((rest, [wall_s - python_s, 0]))
    for name, (seconds, calls) in ordered:
        per_call = f"{1e6 * seconds / calls:.1f}" if calls else ""
        per_sim = f"{calls / sim_s:.0f}" if calls else ""
        lines.append(
            f"| {name} | {per_sim} | {per_call} | {1e3 * seconds / sim_s:.3f} "
            f"| {1e6 * seconds / sim_s / steps_per_s:.1f} | {100 * seconds / wall_s:.0f}% |"
        )
    lines.append(
        f"| total | | | {1e3 * wall_s / sim_s:.3f} | {1e6 * wall_s / sim_s / steps_per_s:.1f} "
        "| 100% |"
    )
    lines += [
        "",
        "## 4. Cost of one truth derivative",
        "",
        "| evaluation | us per call | ratio to reference |",
        "| --- | ---: | ---: |",
    ]
    for name, microseconds, ratio in derivatives:
        lines.append(f"| {name} | {microseconds:.1f} | {ratio:.1f} |")
    return "\n".join(lines) + "\n"


def main():
    """Runs every measurement, prints the report and writes it to RESULTS."""
    logging.getLogger("drake").setLevel(logging.WARNING)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per case (best is kept)")
    args = parser.parse_args()
    load_start = os.getloadavg()
    start = time.perf_counter()
    _, hold = load_scenario("hold_point")
    simulate(replace(hold, duration_s=1.0))  # warm-up: first-call imports and caches
    print("real-time factors ...", file=sys.stderr, flush=True)
    rtf_rows = real_time_factors(args.repeat)
    print("plain-numpy reference ...", file=sys.stderr, flush=True)
    reference = plain_reference(hold, args.repeat)
    print("breakdown ...", file=sys.stderr, flush=True)
    parts = breakdown(hold, rtf_rows[0]["after"])
    derivatives = derivative_costs(hold)
    load_end = os.getloadavg()
    text = report(
        args,
        rtf_rows,
        reference,
        parts,
        derivatives,
        load_start,
        load_end,
        time.perf_counter() - start,
    )
    print(text)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(text)


if __name__ == "__main__":
    main()
