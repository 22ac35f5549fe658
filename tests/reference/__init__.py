"""Test-only reference systems: the independent implementations rpod's fast truth is held to.

Not part of the rpod package (pyproject.toml maps only models, systems, planners, diagrams and
scenarios into it), so nothing rpod builds can use them. What is here:

- `orbital_dynamics.OrbitalDynamics`, `rigid_body_attitude.RigidBodyAttitude` and
  `split_truth.SplitTruth`: the systems `rpod.systems.truth.Truth` replaced (the translational
  truth, one body's attitude, and the two wired with `rpod.systems.thruster_bank.ThrusterBank` into a Diagram
  with Truth's constructor and ports), kept as the second implementation it is checked and timed
  against (tests/systems/test_truth.py, benchmarks/bench_hold_point.py);
- `eci_reference`: both bodies integrated absolutely in ECI with DOP853, from gravity, LVLH and
  the circular orbit written out there.

Their own tests sit beside them (test_*.py) and import them relatively. From elsewhere, import
them as `tests.reference.<module>` with the repository root on sys.path (tests/systems/conftest.py
and the benchmarks put it there).
"""
