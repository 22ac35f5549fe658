"""Paper 003's figures (planar_approach.figures and campaign_maps) from a synthetic log and
synthetic campaign metrics: written when their keys are logged, absent (and no stale file
left) without them."""

import math

import numpy as np
import pytest

from rpod.diagrams.controllers.planar_approach.campaign_maps import write_campaign_maps
from rpod.diagrams.controllers.planar_approach.figures import FIGURE_NAMES as PLANAR_FIGURE_NAMES
from rpod.diagrams.controllers.planar_approach.figures import square_corners
from rpod.diagrams.plots import FIGURE_NAMES, write_plots

T_S = 20.0  # planned arrival of the synthetic log
OMEGA = 0.1  # target spin [rad/s]


def _wxyz_z(angle):
    """Quaternions (w, x, y, z) of turns about z, (N, 4)."""
    angle = np.asarray(angle, float)
    return np.column_stack(
        [np.cos(angle / 2), np.zeros_like(angle), np.zeros_like(angle), np.sin(angle / 2)]
    )


def _synthetic_log(n: int = 2501) -> dict:
    """A chaser spiralling in from 1 m to 0.36 m over T_S, then co-rotating for 5 s; the flown
    state a few mm off the plan; the thrusters firing in a pattern."""
    t = np.linspace(0.0, T_S + 5.0, n)
    s = np.clip(t / T_S, 0.0, 1.0)
    radius = 1.0 - 0.64 * s
    bearing = 0.75 * math.pi * s + OMEGA * np.maximum(t - T_S, 0.0)
    p = np.column_stack([radius * np.cos(bearing), radius * np.sin(bearing)])
    v = np.gradient(p, t, axis=0)
    yaw = -0.25 * math.pi * s
    flown = np.column_stack([p + 0.003 * np.sin(t)[:, None], yaw, v, np.gradient(yaw, t)])
    plan = np.where((t <= T_S)[:, None], np.column_stack([p, yaw, v, np.gradient(yaw, t)]), np.nan)
    theta_t = OMEGA * t
    on = (np.sin(np.outer(t, np.arange(1, 9))) > 0.7).astype(float)
    zeros = np.zeros((n, 1))
    return {
        "t": t,
        "p_LC_L": np.column_stack([flown[:, :2], zeros]),
        "q_IT": _wxyz_z(theta_t),
        "q_IL": _wxyz_z(np.zeros(n)),
        "thruster_on": on,
        "separation_m": radius - 0.3,
        "planar_flown_state": flown,
        "planar_plan_state": plan,
        "planar_position_error_m": np.where(t <= T_S, 0.003 * np.abs(np.sin(t)) * 2**0.5, np.nan),
        "planar_attitude_error_rad": np.where(t <= T_S, 0.001 * np.cos(t), np.nan),
        "planar_target_yaw_rad": theta_t,
        "planar_relative_velocity_T": v - OMEGA * np.column_stack([-p[:, 1], p[:, 0]]),
        "planar_keepout_state": np.where(radius < 0.6, 2, 1),
        "planar_keepout_q_m": radius - 0.45,
        "planar_goal_L": np.tile(
            [0.36 * math.cos(0.75 * math.pi), 0.36 * math.sin(0.75 * math.pi)], (n, 1)
        ),
        "planar_chaser_side_m": np.full(n, 0.3),
        "planar_target_side_m": np.full(n, 0.3),
        "planar_body_wrench_desired": np.column_stack(
            [zeros, zeros, 1e-3 * np.sin(t), 0.01 * np.cos(t), 0.01 * np.sin(t), zeros]
        ),
    }


def test_square_corners_are_a_turned_square():
    corners = square_corners((1.0, 2.0), math.pi / 2, 0.3)
    assert corners.shape == (5, 2)
    np.testing.assert_allclose(corners[0], corners[-1])
    np.testing.assert_allclose(corners.mean(axis=0), [1.0, 2.0], atol=0.1)  # closed: 5 points
    # The +x face (corners 0 and 3) of a square turned by 90 deg faces +y.
    np.testing.assert_allclose(0.5 * (corners[0] + corners[3]), [1.0, 2.15], atol=1e-12)
    sides = np.linalg.norm(np.diff(corners, axis=0), axis=1)
    np.testing.assert_allclose(sides, 0.3, atol=1e-12)


def test_the_four_figures_are_written_for_a_planar_log(tmp_path):
    paths = write_plots(_synthetic_log(), tmp_path, "synthetic")
    names = [p.name for p in paths]
    assert [n for n in names if n.startswith("planar_")] == list(PLANAR_FIGURE_NAMES)
    for name in PLANAR_FIGURE_NAMES:
        assert (tmp_path / name).stat().st_size > 10_000


def test_no_planar_figure_without_its_keys(tmp_path):
    log = _synthetic_log()
    write_plots(log, tmp_path)  # first a full run into the folder
    plain = {k: v for k, v in log.items() if not k.startswith("planar_")}
    names = [p.name for p in write_plots(plain, tmp_path)]
    assert not set(names) & set(PLANAR_FIGURE_NAMES)
    assert not any((tmp_path / name).exists() for name in PLANAR_FIGURE_NAMES)  # none stale
    assert set(names) <= set(FIGURE_NAMES)
    # Without thruster_on and the desired wrench, only the thrusters' figure is left out.
    partial = {
        k: v for k, v in log.items() if k not in ("thruster_on", "planar_body_wrench_desired")
    }
    names = [p.name for p in write_plots(partial, tmp_path / "partial")]
    assert [n for n in names if n.startswith("planar_")] == [
        n for n in PLANAR_FIGURE_NAMES if n != "planar_thrusters.png"
    ]


def _metrics(omega, thrust, theta, final, rms, safe):
    return {
        "planar_plan_status": "success",
        "planar_omega_target_rad_s": omega,
        "planar_thrust_N": thrust,
        "planar_theta_approach_deg": theta,
        "planar_plan_terminal_position_error_m": final,
        "planar_rms_tracking_error_m": rms,
        "planar_safe": safe,
        "planar_plan_cost_goal": final,
        "planar_plan_cost_kinetic": 0.1,
        "planar_plan_cost_control": 0.05,
    }


def test_campaign_maps_for_both_case_studies(tmp_path):
    case1 = [
        _metrics(w, f, 135.0, 0.05 * w, 0.01 * f, w < 1.0)
        for w in (0.1, 0.6, 1.1, 1.6)
        for f in (0.03, 0.3, 0.6)
    ]
    case1[0]["planar_rms_tracking_error_m"] = None  # a run without a flown error is a blank
    paths = write_campaign_maps(case1, tmp_path)
    assert [p.name for p in paths] == ["planar_case1.png"]
    case2 = [
        _metrics(w, 0.03, a, 0.01 + 0.1 * abs(math.cos(math.radians(a / 2))), 0.01, True)
        for a in range(0, 360, 30)
        for w in (0.5, 1.0)
    ]
    paths = write_campaign_maps(case2, tmp_path)
    assert [p.name for p in paths] == ["planar_case2.png"]
    assert (tmp_path / "planar_case2.png").stat().st_size > 10_000
    assert write_campaign_maps([{"capture_success": True}], tmp_path / "none") == []


@pytest.mark.parametrize("n", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_tiny_logs_do_not_break_the_figures(tmp_path, caplog, n):
    log = {k: v[:n] for k, v in _synthetic_log().items()}
    write_plots(log, tmp_path)  # a figure that fails is logged as a warning, not raised
    assert not [r for r in caplog.records if "planar" in r.getMessage()]
