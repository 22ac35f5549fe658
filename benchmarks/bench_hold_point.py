"""Speed of the truth and of the default scenario: real-time factors and derivative costs.

    python benchmarks/bench_hold_point.py [--repeat N]

Prints two tables and writes them to benchmarks/results/hold_point.md. Every figure is measured
in this run; ratios are to references measured in the same run:
- real-time factors of the bundled scenarios and of variants of hold_point (no recording), and
  the share of the 100x goal each reaches;
- the cost of one truth derivative through Drake (OrbitalDynamics alone, and the whole
  hold_point diagram) against the same equations as a plain Python function (the reference).
"""

import argparse
import dataclasses
import logging
import pathlib
import platform
import time

import numpy as np

from rpod.diagrams.builder import build_diagram, simulate
from rpod.models.gravity import gravity_acceleration_xyz
from rpod.scenarios.loader import load_scenario
from rpod.systems.orbital_dynamics import OrbitalDynamics

GOAL_REAL_TIME_FACTOR = 100.0
RESULTS = pathlib.Path(__file__).resolve().parent / "results" / "hold_point.md"


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


def time_call(function, count: int) -> float:
    """Best of 5 batches: mean seconds per call."""
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(count):
            function()
        best = min(best, (time.perf_counter() - start) / count)
    return best


def real_time_factors(repeat: int) -> list[tuple]:
    _, hold = load_scenario("hold_point")
    _, coast = load_scenario("coast")
    cases = [
        ("hold_point: PWM 10 Hz x 10 slots, two_body_j2 (the goal case)", hold),
        ("hold_point without PWM (duty as throttle)", replace(hold, **{"thrusters.pwm": False})),
        ("hold_point, PWM, two_body (no J2)", replace(hold, **{"orbit.gravity": "two_body"})),
        ("hold_point, PWM, 5 slots per period", replace(hold, **{"thrusters.subdivisions": 5})),
        ("coast: 3000 s, runge_kutta5, no thrusters", coast),
    ]
    rows = []
    for name, scenario in cases:
        summaries = [simulate(scenario).summary for _ in range(repeat)]
        best = max(summaries, key=lambda s: s["real_time_factor"])
        rows.append(
            (
                name,
                best["sim_time_s"],
                best["wall_time_s"],
                best["real_time_factor"],
                best["real_time_factor"] / GOAL_REAL_TIME_FACTOR,
                best["integrator_steps"],
                best["derivative_evaluations"],
                1e6 * best["wall_time_s"] / best["integrator_steps"],
            )
        )
    return rows


def derivative_costs() -> list[tuple]:
    _, hold = load_scenario("hold_point")
    orbital = OrbitalDynamics(hold.orbit, np.array([10.0, -100.0, 5.0]), np.zeros(3), 500.0)
    context = orbital.CreateDefaultContext()
    orbital.GetInputPort("body_wrench").FixValue(context, np.array([0, 0, 0, 1.0, 2.0, 3.0]))
    orbital.GetInputPort("chaser_attitude").FixValue(context, np.array([1.0, 0, 0, 0, 0, 0, 0]))
    orbital.GetInputPort("propellant_mass_flow").FixValue(context, np.zeros(1))
    derivatives = orbital.AllocateTimeDerivatives()
    x = context.get_continuous_state_vector().CopyToVector()

    def plain_python_truth():
        """The same equations, no Drake: target gravity, differential gravity, force, mass."""
        a_T = gravity_acceleration_xyz(x[0], x[1], x[2], "two_body_j2")
        a_C = gravity_acceleration_xyz(x[0] + x[6], x[1] + x[7], x[2] + x[8], "two_body_j2")
        inverse_mass = 1.0 / x[12]
        return [
            x[3],
            x[4],
            x[5],
            *a_T,
            x[9],
            x[10],
            x[11],
            a_C[0] - a_T[0] + inverse_mass,
            a_C[1] - a_T[1] + 2 * inverse_mass,
            a_C[2] - a_T[2] + 3 * inverse_mass,
            0.0,
        ]

    diagram, _ = build_diagram(hold)
    diagram_context = diagram.CreateDefaultContext()
    diagram_derivatives = diagram.AllocateTimeDerivatives()
    state = diagram_context.get_mutable_continuous_state_vector()
    base = state.CopyToVector()

    def diagram_derivative():
        # Perturb the state so no cached value is reused, as in an integrator stage.
        state.SetFromVector(base + 1e-9 * np.random.rand(base.size))
        diagram.CalcTimeDerivatives(diagram_context, diagram_derivatives)

    reference = time_call(plain_python_truth, 2000)
    rows = [("plain Python truth equations (reference)", reference)]
    rows.append(
        (
            "OrbitalDynamics.CalcTimeDerivatives (Drake, fixed inputs)",
            time_call(lambda: orbital.CalcTimeDerivatives(context, derivatives), 2000),
        )
    )
    rows.append(
        (
            "hold_point diagram CalcTimeDerivatives (3 continuous systems)",
            time_call(diagram_derivative, 2000),
        )
    )
    return [(name, seconds * 1e6, seconds / reference) for name, seconds in rows]


def main():
    logging.getLogger("drake").setLevel(logging.WARNING)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2, help="runs per case (best is kept)")
    args = parser.parse_args()
    lines = [
        "# hold_point benchmark",
        "",
        f"Machine: {platform.processor() or platform.machine()}, Python "
        f"{platform.python_version()}; `python benchmarks/bench_hold_point.py --repeat "
        f"{args.repeat}` (best of {args.repeat}).",
        "",
        "## Real-time factor (goal: 100x for the goal case)",
        "",
        "| case | sim s | wall s | real-time factor | share of goal | steps | derivatives "
        "| wall per step (us) |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in real_time_factors(args.repeat):
        lines.append(
            f"| {row[0]} | {row[1]:.0f} | {row[2]:.2f} | {row[3]:.1f} | {row[4]:.2f} | {row[5]} "
            f"| {row[6]} | {row[7]:.0f} |"
        )
    lines += [
        "",
        "## Cost of one truth derivative",
        "",
        "| evaluation | us per call | ratio to reference |",
        "| --- | ---: | ---: |",
    ]
    for name, microseconds, ratio in derivative_costs():
        lines.append(f"| {name} | {microseconds:.1f} | {ratio:.1f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(text)


if __name__ == "__main__":
    main()
