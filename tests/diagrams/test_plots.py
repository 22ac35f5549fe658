"""Tests of rpod.diagrams.plots: the five PNGs, robustness to missing keys, p_TC_T.

Truths: PNGs are read back with matplotlib.image.imread (a truncated or non-PNG file fails there)
and must hold more than one colour. p_TC_T is checked against rotations worked out by hand and
against pydrake's RotationMatrix sample by sample (an implementation independent of the module's
vectorised quaternion formula); 1e-12 m on metre-sized vectors is round-off of a few products.
"""

import logging

import matplotlib.image
import numpy as np
import pytest
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RotationMatrix

from rpod.diagrams.plots import FIGURE_NAMES, chaser_in_target_frame, write_plots

N_ORBIT = 0.0011  # mean motion [rad/s], ~95 min LEO


def _wxyz(axis, angle) -> np.ndarray:
    axis = np.asarray(axis, dtype=float)
    return Quaternion(AngleAxis(angle, axis / np.linalg.norm(axis)).rotation()).wxyz()


def _synthetic_log(num_samples=5000, num_thrusters=12, seed=0) -> dict[str, np.ndarray]:
    """A CW-like inward spiral (500 m -> ~5 m), a tumbling target, random thruster commands."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 3.0 * 2.0 * np.pi / N_ORBIT, num_samples)
    a = 500.0 * np.exp(-t / t[-1] * np.log(100.0))  # shrinking ellipse amplitude
    p_LC_L = np.column_stack(
        [
            a * np.cos(N_ORBIT * t),
            -2.0 * a * np.sin(N_ORBIT * t),
            0.3 * a * np.cos(N_ORBIT * t + 0.5),
        ]
    )
    v_LC_L = np.gradient(p_LC_L, t, axis=0)
    # L turns about its z axis once per orbit; the target tumbles about a tilted axis.
    q_IL = np.array([_wxyz([0.0, 0.0, 1.0], N_ORBIT * ti) for ti in t])
    q_IT = np.array([_wxyz([1.0, 2.0, 3.0], 0.02 * ti) for ti in t])
    duty = rng.uniform(0.0, 1.0, (num_samples, num_thrusters)) * (
        rng.random((num_samples, 1)) < 0.3
    )
    on = (rng.random(duty.shape) < duty).astype(float)
    wrench = np.column_stack(
        [0.1 * rng.standard_normal((num_samples, 3)), 2.0 * rng.standard_normal((num_samples, 3))]
    )
    return {
        "t": t,
        "p_LC_L": p_LC_L,
        "v_LC_L": v_LC_L,
        "q_IT": q_IT,
        "w_IT_T": np.tile([0.0, 0.0, 0.02], (num_samples, 1)),
        "q_IC": np.tile([1.0, 0.0, 0.0, 0.0], (num_samples, 1)),
        "w_IC_C": np.zeros((num_samples, 3)),
        "q_IL": q_IL,
        "thruster_duty": duty,
        "thruster_on": on,
        "body_wrench": wrench,
        "propellant_kg": 10.0 - 1e-4 * np.cumsum(on.sum(axis=1)) * (t[1] - t[0]),
        "separation_m": np.linalg.norm(p_LC_L, axis=1) - 1.5,
        "hold_point_L": np.where(t[:, None] < t[-1] / 2, [0.0, -100.0, 0.0], [0.0, -5.0, 0.0]),
    }


def _assert_valid_png(path) -> None:
    image = matplotlib.image.imread(path)  # raises on a truncated or non-PNG file
    assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100, image.shape
    rgb = image[..., :3].reshape(-1, 3)
    packed = (np.round(rgb * 255).astype(np.int64) * [65536, 256, 1]).sum(axis=1)
    assert len(np.unique(packed)) > 10, f"{path.name} is (almost) a single colour"
    # Not just a title on white: a few percent of the pixels carry ink.
    assert np.mean(rgb.min(axis=1) < 0.9) > 0.01, f"{path.name} is nearly blank"


def test_all_five_pngs_written(tmp_path, caplog):
    out = tmp_path / "plots"  # does not exist yet: write_plots creates it
    with caplog.at_level(logging.WARNING, logger="rpod.diagrams.plots"):
        paths = write_plots(_synthetic_log(), out, title="synthetic")
    assert [p.name for p in paths] == list(FIGURE_NAMES)
    assert not caplog.records, [r.getMessage() for r in caplog.records]
    for path in paths:
        assert path.parent == out and path.is_file()
        _assert_valid_png(path)
    assert not list(out.glob(".*.tmp")), "temporary files left behind"


def test_accepts_an_npz_log(tmp_path):
    np.savez(tmp_path / "log.npz", **_synthetic_log(num_samples=200, num_thrusters=3))
    with np.load(tmp_path / "log.npz") as log:
        paths = write_plots(log, tmp_path / "plots")
    assert len(paths) == len(FIGURE_NAMES)


def test_missing_thruster_keys_write_the_others(tmp_path):
    log = _synthetic_log(num_samples=300)
    del log["thruster_duty"]
    del log["thruster_on"]
    paths = write_plots(log, tmp_path)
    assert [p.name for p in paths] == [n for n in FIGURE_NAMES if n != "duty.png"]
    for path in paths:
        _assert_valid_png(path)


def test_stale_figure_removed_when_no_longer_drawable(tmp_path):
    write_plots(_synthetic_log(num_samples=100), tmp_path)
    assert (tmp_path / "duty.png").is_file()
    log = _synthetic_log(num_samples=100)
    log["thruster_duty"] = np.zeros((100, 0))  # a scenario without thrusters
    log["thruster_on"] = np.zeros((100, 0))
    paths = write_plots(log, tmp_path)
    assert "duty.png" not in [p.name for p in paths]
    assert not (tmp_path / "duty.png").exists()


# Two by default (the same drawing code skips any missing key); the other three slow.
@pytest.mark.parametrize(
    "drop",
    [
        ["body_wrench", "propellant_kg"],
        pytest.param(["q_IT"], marks=pytest.mark.slow),  # no p_TC_T
        pytest.param(["separation_m", "hold_point_L"], marks=pytest.mark.slow),
        ["t"],  # falls back to the sample index
        pytest.param(["p_LC_L"], marks=pytest.mark.slow),
    ],
)
def test_partial_logs_never_crash(tmp_path, drop, caplog):
    log = _synthetic_log(num_samples=200, num_thrusters=4)
    for key in drop:
        del log[key]
    with caplog.at_level(logging.WARNING, logger="rpod.diagrams.plots"):
        paths = write_plots(log, tmp_path)
    assert not caplog.records, [r.getMessage() for r in caplog.records]
    assert paths
    for path in paths:
        _assert_valid_png(path)


def test_malformed_and_degenerate_logs(tmp_path):
    assert write_plots({}, tmp_path / "empty") == []
    log = _synthetic_log(num_samples=50, num_thrusters=2)
    log["body_wrench"] = log["body_wrench"][:10]  # wrong length: skipped with a warning
    log["q_IT"][5] = 0.0  # zero quaternion: a NaN sample, not a crash
    log["separation_m"][20:] = -0.01  # penetration: linear scale
    paths = write_plots(log, tmp_path / "bad")
    assert len(paths) == len(FIGURE_NAMES)
    one = {k: v[:1] for k, v in _synthetic_log(num_samples=10, num_thrusters=2).items()}
    assert len(write_plots(one, tmp_path / "one")) == len(FIGURE_NAMES)


def test_chaser_in_target_frame_hand_cases():
    identity = np.array([1.0, 0.0, 0.0, 0.0])
    rz90 = _wxyz([0, 0, 1], np.pi / 2)  # maps x -> y, y -> -x
    rx90 = _wxyz([1, 0, 0], np.pi / 2)
    p = np.array([1.0, 0.0, 0.0])
    # L = I; T turned +90 deg about z: the I-x direction is -y in T.
    np.testing.assert_allclose(chaser_in_target_frame(rz90, identity, p), [0, -1, 0], atol=1e-15)
    # T = I; L turned +90 deg about z: L-x is I-y = T-y.
    np.testing.assert_allclose(chaser_in_target_frame(identity, rz90, p), [0, 1, 0], atol=1e-15)
    # T aligned with L: the components do not change.
    q = np.array([rx90, rz90])
    pts = np.array([[1.0, 2.0, 3.0], [-4.0, 5.0, 0.5]])
    np.testing.assert_allclose(chaser_in_target_frame(q, q, pts), pts, atol=1e-14)
    # Non-unit and sign-flipped quaternions describe the same rotations.
    np.testing.assert_allclose(
        chaser_in_target_frame(-3.0 * rz90, 0.5 * identity, p), [0, -1, 0], atol=1e-15
    )
    # L turned +90 about x (L-y = I-z), T turned +90 about z: p_LC_L = y_L = I-z = T-z.
    np.testing.assert_allclose(
        chaser_in_target_frame(rz90, rx90, [0.0, 1.0, 0.0]), [0, 0, 1], atol=1e-15
    )


def test_chaser_in_target_frame_matches_pydrake():
    rng = np.random.default_rng(1)
    q_IT = rng.standard_normal((50, 4))
    q_IL = rng.standard_normal((50, 4))
    p = 100.0 * rng.standard_normal((50, 3))
    expected = np.array(
        [
            RotationMatrix(Quaternion(a / np.linalg.norm(a)))
            .inverse()
            .multiply(RotationMatrix(Quaternion(b / np.linalg.norm(b))))
            .multiply(c)
            for a, b, c in zip(q_IT, q_IL, p)
        ]
    )
    np.testing.assert_allclose(chaser_in_target_frame(q_IT, q_IL, p), expected, atol=1e-12)


def test_envelope_keeps_extremes_in_time_order():
    from rpod.diagrams.plots import envelope

    rng = np.random.default_rng(2)
    t = np.sort(rng.uniform(0.0, 100.0, 5003))
    y = rng.standard_normal((5003, 3))
    y[100:120, 1] = np.nan  # a gap: NaN out, no crash
    t_env, y_env = envelope(t, y, buckets=500)
    assert t_env.shape == y_env.shape and len(y_env) <= 1000
    np.testing.assert_array_equal(np.nanmax(y_env, axis=0), np.nanmax(y, axis=0))
    np.testing.assert_array_equal(np.nanmin(y_env, axis=0), np.nanmin(y, axis=0))
    for j in range(3):
        finite = np.isfinite(t_env[:, j])
        assert np.all(np.diff(t_env[finite, j]) >= 0.0)


def test_interrupted_save_leaves_no_truncated_png(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    log = _synthetic_log(num_samples=100, num_thrusters=2)
    write_plots(log, tmp_path)
    before = (tmp_path / FIGURE_NAMES[0]).read_bytes()

    def broken_savefig(self, f, **kwargs):
        f.write(b"\x89PNG\r\n\x1a\n truncated")  # a PNG signature and then nothing
        raise KeyboardInterrupt

    monkeypatch.setattr(Figure, "savefig", broken_savefig)
    with pytest.raises(KeyboardInterrupt):
        write_plots(log, tmp_path)
    # The interrupted figure keeps its previous, complete version; no temporary file is left.
    assert (tmp_path / FIGURE_NAMES[0]).read_bytes() == before
    assert not list(tmp_path.glob(".*.tmp"))

    def failing_savefig(self, f, **kwargs):
        f.write(b"\x89PNG\r\n\x1a\n truncated")
        raise OSError("disk full")

    monkeypatch.setattr(Figure, "savefig", failing_savefig)
    assert write_plots(log, tmp_path) == []  # logged, not raised
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob(".*.tmp"))


def test_propellant_used_is_drawn_positive_with_its_total(tmp_path):
    """The log's propellant_kg is the mass used since t = 0; it was drawn negated, titled
    'total 0 kg'."""
    from rpod.diagrams import plots

    log = _synthetic_log(num_samples=200)
    log["propellant_kg"] = np.linspace(0.0, 0.25, 200)
    figure = plots._figure_thrust(plots.RunLog(log), "")
    axes = next(ax for ax in figure.axes if ax.get_ylabel() == "propellant used [kg]")
    assert axes.get_title() == "propellant used (total 0.25 kg)"
    assert np.all(axes.lines[0].get_ydata() >= 0.0)
