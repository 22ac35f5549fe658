"""Tests of the figures of several plans in soft_capture.plan_figures (paper 000's Figs. 5-9).

Truths: a PNG is read back with matplotlib.image.imread (a truncated or non-PNG file fails there)
and must hold more than one colour; a failure status must put its own colour (tab:red, the first
failure style) in Fig. 8 and an all-success campaign must not; empty or mismatched input raises
ValueError and writes no file.
"""

import matplotlib.image
import numpy as np
import pytest
from matplotlib.colors import to_rgb

from rpod.diagrams.controllers.soft_capture.plan_figures import (
    SCP_FIGURE_NAMES,
    write_alpha_overlay_plot,
    write_scp_correction_plots,
    write_start_outcomes_plot,
)


def _read_png(path) -> np.ndarray:
    assert path.exists() and path.stat().st_size > 0
    image = matplotlib.image.imread(path)
    assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100
    assert (image[..., :3] != image[0, 0, :3]).any(), "a blank image"
    return image


def _has_colour(image: np.ndarray, colour: str, tolerance: float = 0.02) -> bool:
    """True when some pixel is colour (within tolerance on each channel)."""
    distance = np.abs(image[..., :3] - np.asarray(to_rgb(colour))).max(axis=-1)
    return bool((distance < tolerance).any())


def _cube(half: float) -> np.ndarray:
    return half * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def _iterate(N: int, dip: float) -> dict:
    """A straight approach from 20 m to the capture point with alpha dipping to `dip`."""
    t = np.arange(N, dtype=float)
    s = t / (N - 1)
    r = np.outer(1.0 - s, [20.0, 5.0, -3.0]) + np.outer(s, [0.0, 0.0, 5.4])
    v = np.gradient(r, t, axis=0)
    alpha = 1.0 + 9.0 * (1.0 - s) + (dip - 1.0) * np.exp(-(((s - 0.8) / 0.05) ** 2))
    return {
        "t": t,
        "x": np.hstack([r, v]),
        "u": np.tile([10.0, -20.0, 5.0], (N - 1, 1)) * np.sin(t[:-1])[:, None],
        "q_LT": np.tile([1.0, 0.0, 0.0, 0.0], (N, 1)),
        "q_LC": np.tile([1.0, 0.0, 0.0, 0.0], (N, 1)),
        "alpha": alpha,
        "V_target": _cube(1.5),
        "V_chaser": _cube(1.0),
        "D_t": np.array([0.0, 0.0, 2.7]),
        "theta_dock": np.radians(30.0),
        "U_max": 100.0,
        "alpha_min": 1.3,
    }


def test_scp_correction_plots_written(tmp_path):
    iterates = [_iterate(30, 0.8), _iterate(30, 1.1), _iterate(30, 1.4)]
    written = write_scp_correction_plots(iterates, tmp_path / "figs", title="synthetic")
    assert [p.name for p in written] == list(SCP_FIGURE_NAMES)
    for path in written:
        _read_png(path)


def test_scp_correction_plots_of_problem2_alone(tmp_path):
    """One iterate (Problem 2 passed the hard test): the three figures of it alone."""
    written = write_scp_correction_plots([_iterate(20, 1.5)], tmp_path)
    assert len(written) == 3
    for path in written:
        _read_png(path)


def test_scp_correction_plots_reject_empty(tmp_path):
    with pytest.raises(ValueError, match="no iterates"):
        write_scp_correction_plots([], tmp_path)
    with pytest.raises(ValueError, match="fewer than two knots"):
        write_scp_correction_plots([_iterate(20, 0.8) | {"t": np.zeros(1)}], tmp_path)
    assert not any(tmp_path.iterdir())


def test_start_outcomes_plot_colours_failures(tmp_path):
    rng = np.random.default_rng(0)
    range_m, tumble = rng.uniform(15.0, 50.0, 40), rng.uniform(0.0, 10.0, 40)
    statuses = ["success"] * 36 + ["no_feasible_horizon"] * 3 + ["scp_max_iterations"]
    mixed = _read_png(
        write_start_outcomes_plot(tmp_path / "mixed.png", range_m, tumble, statuses, "mixed")
    )
    clean = _read_png(
        write_start_outcomes_plot(tmp_path / "clean.png", range_m, tumble, ["success"] * 40)
    )
    assert _has_colour(mixed, "tab:red") and _has_colour(mixed, "tab:orange")
    assert not _has_colour(clean, "tab:red")


def test_start_outcomes_plot_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="no starts"):
        write_start_outcomes_plot(tmp_path / "a.png", [], [], [])
    with pytest.raises(ValueError, match="differ"):
        write_start_outcomes_plot(tmp_path / "b.png", [20.0, 30.0], [1.0], ["success"] * 2)
    assert not any(tmp_path.iterdir())


def test_alpha_overlay_plot_written(tmp_path):
    plans = [
        (_iterate(N, dip)["t"], _iterate(N, dip)["alpha"]) for N, dip in ((30, 1.2), (45, 1.05))
    ]
    path = write_alpha_overlay_plot(
        tmp_path / "fig9.png",
        plans,
        alpha_min=1.3,
        title="synthetic",
        colour_values=[20.0, 40.0],
        colour_label="start range [m]",
        labels=["start 0", "start 1"],
    )
    _read_png(path)
    # Plain colours and a metric that touches zero (no log scale) draw too.
    _read_png(write_alpha_overlay_plot(tmp_path / "flat.png", [([0.0, 1.0], [0.0, 2.0])], 1.3))


def test_alpha_overlay_plot_rejects_bad_input(tmp_path):
    plan = (np.arange(5.0), np.linspace(5.0, 2.0, 5))
    with pytest.raises(ValueError, match="no plans"):
        write_alpha_overlay_plot(tmp_path / "a.png", [], 1.3)
    with pytest.raises(ValueError, match="one length"):
        write_alpha_overlay_plot(tmp_path / "b.png", [(np.arange(4.0), plan[1])], 1.3)
    with pytest.raises(ValueError, match="colour_values"):
        write_alpha_overlay_plot(tmp_path / "c.png", [plan], 1.3, colour_values=[1.0, 2.0])
    with pytest.raises(ValueError, match="labels"):
        write_alpha_overlay_plot(tmp_path / "d.png", [plan, plan], 1.3, labels=["only one"])
    assert not any(tmp_path.iterdir())
