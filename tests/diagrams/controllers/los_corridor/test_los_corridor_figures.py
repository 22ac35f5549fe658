"""Tests of rpod.diagrams.controllers.los_corridor's figures and its metrics'
`violation_summary`: paper 004's LOS-corridor figures.

Truths: PNGs are read back with matplotlib.image.imread and must carry ink (as in test_plots);
the figures of a run without los_* keys are byte-for-byte those of the same run with them (Agg
renders deterministically); `violation_summary` and `code_runs` against cases worked out by hand.
The synthetic run: a target spinning at 2 deg/s about z_T, a chaser spiralling down the docking
axis +y_T from 200 m to a 10 m hold inside the corridor, pushed out through the faces for
~25 s around t = 215 s (the MPC infeasible and the fallbacks active there).
"""

import logging
import math

import matplotlib.image
import numpy as np
import pytest

from rpod.diagrams.controllers.los_corridor import LOG_SHAPES, violation_summary
from rpod.diagrams.controllers.los_corridor import figures as plots_los
from rpod.diagrams.controllers.los_corridor.figures import FIGURE_NAMES as LOS_FIGURE_NAMES
from rpod.diagrams.controllers.los_corridor.figures import _floor_y, section_slopes
from rpod.diagrams.plots import FIGURE_NAMES, RunLog, code_runs, write_plots
from rpod.diagrams.target_frame import _rotate
from rpod.models.los_corridor import LosCorridor

OMEGA_T = math.radians(2.0)  # target spin about z_T [rad/s]
N_ORBIT = 0.0011  # mean motion [rad/s]
A_MAX = 0.1  # [m/s^2]


def _about_z(angle: np.ndarray) -> np.ndarray:
    return np.column_stack(
        [np.cos(angle / 2), np.zeros_like(angle), np.zeros_like(angle), np.sin(angle / 2)]
    )


def _los_log(num_samples=1201, t_end=600.0, faces=8) -> dict[str, np.ndarray]:
    t = np.linspace(0.0, t_end, num_samples)
    corridor = LosCorridor(faces=faces)
    tan_a = math.tan(corridor.half_angle_rad)
    y = 10.0 + 190.0 * np.exp(-t / 90.0)
    bump = np.clip(np.cos(np.pi * (t - 215.0) / 40.0), 0.0, None) * (np.abs(t - 215.0) < 20.0)
    rho = (0.3 + 0.85 * bump) * tan_a * y  # 1.15 tan(alpha) y at the peak: outside every face
    p_TC_T = np.column_stack([rho * np.cos(0.05 * t), y, rho * np.sin(0.05 * t)])
    q_IT, q_IL = _about_z(OMEGA_T * t), _about_z(N_ORBIT * t)
    conj = np.array([1.0, -1.0, -1.0, -1.0])
    p_LC_L = _rotate(q_IL * conj, _rotate(q_IT, p_TC_T))  # R_LI R_IT p_TC_T
    slack = corridor.slack(p_TC_T)
    slack[:, :faces] *= math.cos(corridor.half_angle_rad)  # faces as distances [m]
    r = np.linalg.norm(p_TC_T, axis=1)
    r_sync = 2.0 * A_MAX / OMEGA_T**2
    regime = np.where(r > r_sync, 0, np.where(np.abs(r - 10.0) < 0.5, 2, 1))
    nominal = 0.25 * np.column_stack([np.sin(t / 30.0), np.cos(t / 45.0), np.sin(t / 70.0)])
    command = np.clip(nominal, -A_MAX, A_MAX)
    applied = command + 0.01 * np.sin(7.0 * t)[:, None]
    status = np.zeros(num_samples, dtype=int)
    status[0] = -1
    status[::97] = 1
    infeasible = bump > 0.6
    status[infeasible] = 2
    fallback = np.where(infeasible, np.where(t < 215.0, 1, 2), 0)
    return {
        "t": t,
        "p_LC_L": p_LC_L,
        "v_LC_L": np.gradient(p_LC_L, t, axis=0),
        "q_IT": q_IT,
        "q_IL": q_IL,
        "q_IC": np.tile([1.0, 0.0, 0.0, 0.0], (num_samples, 1)),
        "los_range_m": r,
        "los_sync_range_m": np.full(num_samples, r_sync),
        "los_hold_point_T": np.tile([0.0, 10.0, 0.0], (num_samples, 1)),
        "los_face_distance_m": slack,
        "los_command_L": command,
        "los_nominal_L": nominal,
        "los_applied_L": applied,
        "los_regime": regime,
        "los_mpc_status": status,
        "los_fallback": fallback,
        "los_a_max_m_s2": np.full(num_samples, A_MAX),
        "los_half_angle_deg": np.full(num_samples, 30.0),
    }


def _assert_valid_png(path) -> None:
    image = matplotlib.image.imread(path)  # raises on a truncated or non-PNG file
    assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100, image.shape
    rgb = image[..., :3].reshape(-1, 3)
    packed = (np.round(rgb * 255).astype(np.int64) * [65536, 256, 1]).sum(axis=1)
    assert len(np.unique(packed)) > 10, f"{path.name} is (almost) a single colour"
    assert np.mean(rgb.min(axis=1) < 0.9) > 0.01, f"{path.name} is nearly blank"


def _base_names(log) -> list[str]:
    """The figures of plots.py a log of these keys draws (no thrusters, wrench or separation)."""
    return ["trajectory_lvlh.png", "trajectory_target_body.png", "separation.png"]


def test_los_pngs_written(tmp_path, caplog):
    log = _los_log()
    depth, duration, first = violation_summary(log["t"], log["los_face_distance_m"])
    assert depth > 0.5 and 10.0 < duration < 40.0 and 195.0 < first < 215.0  # the synthetic case
    with caplog.at_level(logging.WARNING, logger="rpod.diagrams"):
        paths = write_plots(log, tmp_path, title="los synthetic")
    assert not caplog.records, [r.getMessage() for r in caplog.records]
    assert [p.name for p in paths] == _base_names(log) + list(LOS_FIGURE_NAMES)
    for path in paths:
        _assert_valid_png(path)
    assert not list(tmp_path.glob(".*.tmp"))


def test_another_face_count_is_drawn(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="rpod.diagrams"):
        paths = write_plots(_los_log(num_samples=301, faces=5), tmp_path)
    assert not caplog.records, [r.getMessage() for r in caplog.records]
    assert {p.name for p in paths} >= set(LOS_FIGURE_NAMES)


def test_without_los_keys_neither_and_the_others_unchanged(tmp_path):
    log = _los_log(num_samples=301)
    base = {k: v for k, v in log.items() if not k.startswith("los_")}
    with_los = write_plots(log, tmp_path / "with")
    assert {p.name for p in with_los} >= set(LOS_FIGURE_NAMES)
    without = write_plots(base, tmp_path / "without")
    assert [p.name for p in without] == _base_names(base)
    for path in without:
        assert path.read_bytes() == (tmp_path / "with" / path.name).read_bytes(), path.name
    # The same folder, rerun without LOS data: no stale LOS figure is left.
    write_plots(base, tmp_path / "with")
    assert not any((tmp_path / "with" / name).exists() for name in LOS_FIGURE_NAMES)
    assert set(FIGURE_NAMES).isdisjoint(LOS_FIGURE_NAMES)


def test_malformed_los_key_skipped_with_a_warning(tmp_path, caplog):
    log = _los_log(num_samples=201)
    log["los_face_distance_m"] = log["los_face_distance_m"][:, :3]  # n_f + 1 < 4 columns
    log["los_regime"] = log["los_regime"][:50]  # wrong length
    log["los_hold_point_T"] = log["los_hold_point_T"][:, :2]  # wrong width
    with caplog.at_level(logging.WARNING, logger="rpod.diagrams"):
        paths = write_plots(log, tmp_path / "bad")
    messages = " ".join(r.getMessage() for r in caplog.records)
    for key in ("los_face_distance_m", "los_regime", "los_hold_point_T"):
        assert key in messages, messages
    assert {p.name for p in paths} >= set(LOS_FIGURE_NAMES)  # drawn without those panels
    for path in paths:
        _assert_valid_png(path)
    # Every los key malformed: no LOS figure, the others as before, no exception.
    broken = {k: (v[:7] if k.startswith("los_") else v) for k, v in _los_log(201).items()}
    paths = write_plots(broken, tmp_path / "broken")
    assert [p.name for p in paths] == _base_names(broken)
    # One sample, and a NaN stretch: no exception, both still drawn.
    one = {k: v[:1] for k, v in _los_log(11).items()}
    assert {p.name for p in write_plots(one, tmp_path / "one")} >= set(LOS_FIGURE_NAMES)
    gappy = _los_log(201)
    gappy["los_face_distance_m"][20:60] = np.nan
    gappy["los_mpc_status"] = gappy["los_mpc_status"].astype(float)
    gappy["los_mpc_status"][5:9] = np.nan
    assert {p.name for p in write_plots(gappy, tmp_path / "gappy")} >= set(LOS_FIGURE_NAMES)


def test_a_failing_los_figure_only_warns(tmp_path, monkeypatch, caplog):
    def broken(log, title):
        raise RuntimeError("boom")

    monkeypatch.setattr(plots_los, "figure_los_corridor", broken)
    with caplog.at_level(logging.WARNING, logger="rpod.diagrams.plots"):
        paths = write_plots(_los_log(num_samples=101), tmp_path)
    assert "los_corridor.png" in " ".join(r.getMessage() for r in caplog.records)
    assert [p.name for p in paths] == _base_names({}) + ["los_body_frame.png"]


def test_violation_summary_hand_cases():
    t = np.arange(7.0)
    d = np.array([0.5, -0.0005, -0.002, -0.01, 0.1, -0.003, 0.2])
    # Violating (< -1 mm): samples 2, 3, 5, each held 1 s; the deepest -0.01 m.
    assert violation_summary(t, d) == pytest.approx((0.01, 3.0, 2.0))
    # Exactly -tol is not a violation; a larger tolerance leaves only sample 3.
    assert violation_summary(t, d, tol=0.003) == pytest.approx((0.01, 1.0, 3.0))
    # Non-uniform times: sample 0 holds 1 s, sample 2 holds 0.5 s, the last one the 0.5 s before.
    t = np.array([0.0, 1.0, 3.0, 3.5])
    d = np.array([-0.1, 0.0, -0.2, -0.05])
    assert violation_summary(t, d) == pytest.approx((0.2, 2.0, 0.0))
    # Several planes: the least per sample; NaN columns and NaN rows never violate.
    d2 = np.array([[1.0, np.nan], [0.5, -0.3], [np.nan, np.nan], [-0.02, 2.0]])
    assert violation_summary(t, d2) == pytest.approx((0.3, 2.5, 1.0))
    # No violation; a single sample.
    assert violation_summary(t, np.ones(4)) == (0.0, 0.0, None)
    assert violation_summary([5.0], [-1.0]) == (1.0, 0.0, 5.0)
    with pytest.raises(ValueError):
        violation_summary(t, np.ones(3))


def test_section_slopes_hand_cases():
    tan30 = math.tan(math.radians(30.0))
    # n_f = 8: faces at theta = 0, pi/2, pi, 3 pi/2 bound both sections at tan(alpha).
    np.testing.assert_allclose(section_slopes(math.radians(30.0), 8), [tan30] * 4, rtol=1e-15)
    # n_f = 3: theta = 0, 120, 240 deg. +x: face 1 (cos 0 = 1); -x: faces 2, 3 (-cos 120 = 1/2);
    # +-z: faces 2 and 3 (sin 120 = sqrt(3)/2).
    s = tan30 / (math.sqrt(3.0) / 2.0)
    np.testing.assert_allclose(
        section_slopes(math.radians(30.0), 3), [2.0 * tan30, tan30, s, s], rtol=1e-14
    )
    # Every section point on the boundary is on a face of the corridor, and none is outside.
    corridor = LosCorridor(half_angle_rad=math.radians(25.0), faces=5, floor_m=0.0)
    s_mx, s_px, s_mz, s_pz = section_slopes(corridor.half_angle_rad, corridor.faces)
    edge = np.array([[-s_mx, 1.0, 0.0], [s_px, 1.0, 0.0], [0.0, 1.0, -s_mz], [0.0, 1.0, s_pz]])
    slack = corridor.slack(edge)[:, :-1]
    np.testing.assert_allclose(slack.min(axis=1), 0.0, atol=1e-15)


def test_runs_and_floor_hand_cases():
    values, starts, stops = code_runs(np.array([0, 0, 1, 1, 1, 2, np.nan, 2, 0.0]))
    np.testing.assert_array_equal(values, [0, 1, 2, 2, 0])
    np.testing.assert_array_equal(starts, [0, 2, 5, 7, 8])
    np.testing.assert_array_equal(stops, [2, 5, 6, 8, 9])
    # The floor row's distance is y_T - y_min: y_min recovered, robust to one bad sample.
    p = np.array([[0.0, 5.0, 0.0], [1.0, 3.0, 2.0], [0.0, 2.5, 0.0]])
    faces = np.zeros((3, 9))
    faces[:, 8] = p[:, 1] - 1.5
    faces[2, 8] = 7.0
    assert _floor_y(p, faces) == pytest.approx(1.5)
    assert _floor_y(p, None) is None


def test_every_fallback_the_guidance_logs_has_a_colour_and_a_legend_entry():
    """The far approach's own command (Fallback.NOMINAL) was drawn with no colour or legend."""
    from matplotlib.figure import Figure

    from rpod.systems.los_guidance import Fallback

    assert set(plots_los._FALLBACK) == {int(f) for f in Fallback}
    log = _los_log()
    log["los_fallback"] = np.repeat([3, 0, 1, 2], len(log["t"]) // 4 + 1)[: len(log["t"])]
    ax = Figure().add_subplot()
    edges = np.r_[log["t"], log["t"][-1] + 0.5]
    plots_los._panel_status(ax, RunLog(log, LOG_SHAPES), edges)
    labels = " ".join(text.get_text() for text in ax.get_legend().get_texts())
    assert "far-approach command" in labels and "brake" in labels
