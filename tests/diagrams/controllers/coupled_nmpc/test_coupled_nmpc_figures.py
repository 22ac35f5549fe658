"""Tests of rpod.diagrams.controllers.coupled_nmpc's figures and its gimbal face-angle.

Truths: PNGs are read back with matplotlib.image.imread and must carry ink (as in test_plots);
without coupled_eigenaxis_error_rad no coupled figure is written and a stale one is removed;
`gimbal_face_angles` against cases worked out by hand (0 along the nominal direction, exactly
alpha on a face and at a corner, whose cone angle is atan(sqrt(2) tan(alpha)), pi/2 and pi for
forces across or against it) and against eq. 16's rows from `gimbal_polyhedron` on random
forces; the resultant computed from the thruster forces against eqs. 11-12 by hand.
The synthetic run: a 600 s approach from Sec. IV's start, every error decaying exponentially,
the end effector entering the LOS pyramid at ~100 s, thrusters on the faces of their pyramids,
one thruster off, and some NMPC failures with fallbacks.
"""

import logging
import math

import matplotlib.image
import numpy as np
import pytest

from rpod.diagrams.controllers.coupled_nmpc import (
    LOG_SHAPES,
    gimbal_face_angles,
    outside_summary,
)
from rpod.diagrams.controllers.coupled_nmpc import figures as plots_coupled
from rpod.diagrams.controllers.coupled_nmpc.figures import FIGURE_NAMES as COUPLED_FIGURE_NAMES
from rpod.diagrams.controllers.coupled_nmpc.figures import figure_coupled_thrusters
from rpod.diagrams.plots import RunLog, write_plots
from rpod.models.gimbal import gimbal_polyhedron, thruster_frame_C
from rpod.models.thrusters import gimbaled_cuboid_8

ALPHA = math.pi / 4
LAYOUT = gimbaled_cuboid_8()


def _coupled_log(num_samples=1201, t_end=600.0) -> dict[str, np.ndarray]:
    t = np.linspace(0.0, t_end, num_samples)
    decay = np.exp(-t / 60.0)
    p = np.outer(np.exp(-t / 120.0), [-1.1394, 113.0847, -7.6204])
    w = 0.02 * np.column_stack([np.sin(t / 20.0), np.cos(t / 25.0), np.sin(t / 30.0)])
    w *= decay[:, None]
    # Thruster k leans on its +i_K face (phi = alpha) with a breathing magnitude; thruster 7 off.
    forces = np.zeros((num_samples, 8, 3))
    for k, thruster in enumerate(LAYOUT.thrusters):
        e_i = thruster_frame_C(thruster)[:, 0]
        direction = thruster.direction_C + math.tan(ALPHA) * e_i
        magnitude = 20.0 * (0.5 + 0.5 * np.sin(t / (40.0 + 5.0 * k)) ** 2)
        forces[:, k] = np.outer(magnitude, direction / np.linalg.norm(direction))
    forces[:, 7] = 0.0
    status = np.zeros(num_samples, dtype=int)
    status[0] = -1
    status[300:320] = 1  # max iterations
    status[700:705] = 4  # failed
    fallback = np.where(status > 0, np.where(status == 1, 1, 2), 0)  # previous plan, zero
    margin = 60.0 * np.exp(-t / 300.0) * np.tanh((t - 100.0) / 30.0)
    return {
        "t": t,
        "coupled_eigenaxis_error_rad": math.pi * np.exp(-t / 40.0),
        "coupled_w_TC_T_rad_s": w,
        "coupled_p_PtPc_T_m": p,
        "coupled_v_PtPc_T_m_s": np.gradient(p, t, axis=0),
        "coupled_thruster_forces_C_N": forces.reshape(num_samples, 24),
        "coupled_force_C_N": forces.sum(axis=1),
        "coupled_torque_C_Nm": np.cross(LAYOUT.p_CK_C[None], forces).sum(axis=1),
        "coupled_los_margin_m": margin,
        "coupled_max_thrust_N": np.full(num_samples, 20.0),
        "coupled_gimbal_half_angle_rad": np.full(num_samples, ALPHA),
        "nmpc_status": status,
        "nmpc_fallback": fallback,
        "nmpc_solve_time_s": 0.5 + 4.0 * np.abs(np.sin(t / 7.0)),
    }


def _assert_valid_png(path) -> None:
    image = matplotlib.image.imread(path)  # raises on a truncated or non-PNG file
    assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100, image.shape
    rgb = image[..., :3].reshape(-1, 3)
    packed = (np.round(rgb * 255).astype(np.int64) * [65536, 256, 1]).sum(axis=1)
    assert len(np.unique(packed)) > 10, f"{path.name} is (almost) a single colour"
    assert np.mean(rgb.min(axis=1) < 0.9) > 0.01, f"{path.name} is nearly blank"


def test_coupled_pngs_written(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="rpod.diagrams"):
        paths = write_plots(_coupled_log(), tmp_path, title="coupled synthetic")
    assert not caplog.records, [r.getMessage() for r in caplog.records]
    assert [p.name for p in paths] == list(COUPLED_FIGURE_NAMES)  # no other key is logged
    for path in paths:
        _assert_valid_png(path)
    assert not list(tmp_path.glob(".*.tmp"))


def test_without_the_eigenaxis_error_no_coupled_figure(tmp_path):
    log = _coupled_log(num_samples=201)
    assert len(write_plots(log, tmp_path)) == 3
    del log["coupled_eigenaxis_error_rad"]
    assert write_plots(log, tmp_path) == []  # every other coupled and nmpc key still there
    assert not any((tmp_path / name).exists() for name in COUPLED_FIGURE_NAMES)  # none stale
    data = RunLog(log, LOG_SHAPES)
    for make in (
        plots_coupled.figure_coupled_state,
        plots_coupled.figure_coupled_thrusters,
        plots_coupled.figure_coupled_nmpc,
    ):
        assert make(data, "") is None


def test_degenerate_logs_still_draw(tmp_path, caplog):
    # One sample; NaN stretches; the status as floats with NaN; forces of the wrong width.
    one = {k: v[:1] for k, v in _coupled_log(11).items()}
    assert [p.name for p in write_plots(one, tmp_path / "one")] == list(COUPLED_FIGURE_NAMES)
    gappy = _coupled_log(201)
    gappy["coupled_p_PtPc_T_m"][20:60] = np.nan
    gappy["nmpc_status"] = gappy["nmpc_status"].astype(float)
    gappy["nmpc_status"][5:9] = np.nan
    gappy["coupled_thruster_forces_C_N"] = gappy["coupled_thruster_forces_C_N"][:, :21]
    with caplog.at_level(logging.WARNING, logger="rpod.diagrams"):
        paths = write_plots(gappy, tmp_path / "gappy")
    messages = " ".join(r.getMessage() for r in caplog.records)
    assert "coupled_thruster_forces_C_N" in messages and "could not draw" not in messages
    assert [p.name for p in paths] == list(COUPLED_FIGURE_NAMES)  # force and torque panels only
    for path in paths:
        _assert_valid_png(path)


def test_resultant_from_the_thruster_forces_when_not_logged():
    log = _coupled_log(num_samples=101)
    F = log["coupled_thruster_forces_C_N"].reshape(-1, 8, 3)
    expected_force = log.pop("coupled_force_C_N")
    expected_torque = log.pop("coupled_torque_C_Nm")
    # By hand at one sample: f = sum f_k (eq. 11), tau = sum p_k x f_k (eq. 12).
    i = 37
    tau = sum(np.cross(LAYOUT.p_CK_C[k], F[i, k]) for k in range(8))
    np.testing.assert_allclose(expected_torque[i], tau, atol=1e-12)
    fig = figure_coupled_thrusters(RunLog(log, LOG_SHAPES), "")
    force_ax, torque_ax = fig.axes[0], fig.axes[1]
    assert "from the thruster forces" in force_ax.get_title()
    for ax, expected in ((force_ax, expected_force), (torque_ax, expected_torque)):
        for j in range(3):
            np.testing.assert_allclose(ax.lines[j].get_ydata(), expected[:, j], atol=1e-12)


def test_gimbal_face_angle_hand_cases():
    thruster = LAYOUT.thrusters[2]
    R_CK = thruster_frame_C(thruster)
    n, e_i, e_k = thruster.direction_C, R_CK[:, 0], R_CK[:, 2]
    t = math.tan(ALPHA)
    cases = [
        (7.0 * n, 0.0),  # along the nominal direction
        (n + t * e_i, ALPHA),  # on the +i_K face
        (n - t * e_k, ALPHA),  # on the -k_K face
        (n + 0.5 * t * e_i - 0.2 * t * e_k, math.atan(0.5 * t)),  # inside, the i_K face nearer
        (n + t * (e_i + e_k), ALPHA),  # the corner: on two faces
        (n + 2.0 * t * e_k, math.atan(2.0 * t)),  # outside the k_K face
        (e_k, math.pi / 2),  # across the nominal direction
        (-n, math.pi),  # against it
    ]
    for f, expected in cases:
        F = np.zeros((8, 3))
        F[2] = 3.0 * f
        phi = gimbal_face_angles(LAYOUT, F)
        assert phi.shape == (8,)
        assert phi[2] == pytest.approx(expected, abs=1e-14), (f, expected)
        assert np.isnan(phi[[0, 1, 3, 4, 5, 6, 7]]).all()  # zero force: no direction
    # The corner's cone angle is larger than the limit: atan(sqrt(2) tan(alpha)) = 54.7 deg.
    corner = n + t * (e_i + e_k)
    cone = math.acos(corner @ n / np.linalg.norm(corner))
    assert math.degrees(cone) == pytest.approx(54.7356, abs=1e-4)
    # A force at or below min_force_N is not measured.
    F = np.zeros((8, 3))
    F[2] = 1e-3 * (n + t * e_i)
    assert np.isnan(gimbal_face_angles(LAYOUT, F, min_force_N=0.01)[2])
    assert gimbal_face_angles(LAYOUT, F)[2] == pytest.approx(ALPHA, abs=1e-14)


def test_gimbal_face_angle_is_within_alpha_exactly_when_eq_16_holds():
    rng = np.random.default_rng(12)
    F = rng.normal(size=(2000, 8, 3))
    F[:500] += 2.0 * LAYOUT.directions_C  # many inside
    phi = gimbal_face_angles(LAYOUT, F.reshape(2000, 24))
    assert phi.shape == (2000, 8)
    for k, thruster in enumerate(LAYOUT.thrusters):
        A, b = gimbal_polyhedron(thruster)  # eq. 16: A f <= b
        slack = F[:, k] @ A.T - b
        clear = np.all(np.abs(slack) > 1e-9, axis=1) & (np.abs(phi[:, k] - ALPHA) > 1e-9)
        inside = np.all(slack <= 0.0, axis=1)
        np.testing.assert_array_equal((phi[:, k] <= ALPHA)[clear], inside[clear])
        assert 50 < np.sum(inside[clear]) < 1950  # both sides exercised


def test_outside_summary_hand_cases():
    t = np.arange(6.0)
    # Outside (< 0) at samples 0, 1 and 3, each held 1 s; the deepest 4 m; inside from t = 4 on.
    assert outside_summary(t, np.array([-4.0, -1.0, 0.5, -0.2, 0.0, 3.0])) == (3.0, 4.0, 4.0)
    # Ends outside: no exit; the last sample held as long as the one before.
    assert outside_summary(t, np.array([1.0, 1.0, 1.0, 1.0, -2.0, -1.0])) == (2.0, 2.0, None)
    assert outside_summary(t, np.ones(6)) == (0.0, 0.0, None)


def test_the_los_panel_counts_the_samples_the_outcome_line_counts():
    """coupled_nmpc.png said 'outside at the end' while the line said the LOS was held: the
    panel counted every negative margin, the outcome only those more than 1 mm out and beyond
    0.1 m of the rock (where the pyramid's apex makes the margin noise)."""
    from matplotlib.figure import Figure

    from rpod.diagrams.controllers.coupled_nmpc import los_counted_outside

    log = _coupled_log()
    n = len(log["t"])
    margin = np.full(n, 0.5)
    margin[:200] = -2.0  # outside until t = 100 s
    margin[-50:] = -0.0005  # half a millimetre out at the end: not counted
    log["coupled_los_margin_m"] = margin
    distance = np.linalg.norm(log["coupled_p_PtPc_T_m"], axis=1)
    assert np.flatnonzero(los_counted_outside(margin, distance))[-1] == 199
    ax = Figure().add_subplot()
    plots_coupled._panel_los(ax, RunLog(log, LOG_SHAPES), np.r_[log["t"], log["t"][-1] + 0.5])
    assert "inside from t = 100 s on" in ax.get_title()
