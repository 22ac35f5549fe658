"""The relative-navigation EKF against a truth it does not share: consistency (NEES and NIS over
a Monte Carlo, Bar-Shalom, Li & Kirubarajan, "Estimation with Applications to Tracking and
Navigation", 2001, Sec. 5.4), the inertia ratios on a 3-D tumble, their unobservability on a
principal-axis spin, outliers and a dropout.

The truth: CW translation and torque-free Euler rotation by RK4 at 0.05 s (a quarter of the
filter's step, integrated for all runs at once), driven by the white noise the filter's
ProcessNoise states (so that consistency tests the filter's mathematics, not a mismatch).
"""

import numpy as np
import pytest
from scipy.stats import chi2

from rpod.models import relative_navigation as nav
from rpod.models.frames import quaternion_product, rotation_vector_quaternion

N_RAD_S = 0.0011  # ~500 km circular orbit
TRUTH_STEP_S = 0.05
FIX_PERIOD_S = 0.5  # the pose sensor at 2 Hz
SIGMA_ATTITUDE_RAD = np.radians(2.0)
SETTINGS = nav.FilterSettings()
PRIOR = SETTINGS.prior
NOISE = SETTINGS.noise


def position_sigma(p_LC_L) -> float:
    """max(1 cm, 1 % of range): the pose sensor's default."""
    return max(0.01, 0.01 * float(np.linalg.norm(p_LC_L)))


def _rates(x, k):
    """d/dt of the batch of truths x (runs, 13): [p, v, q, w]."""
    p, v, q, w = x[:, 0:3], x[:, 3:6], x[:, 6:10], x[:, 10:13]
    n = N_RAD_S
    a = np.column_stack([3 * n * n * p[:, 0] + 2 * n * v[:, 1], -2 * n * v[:, 0], -n * n * p[:, 2]])
    qw, qx, qy, qz = q.T
    wx, wy, wz = w.T
    q_dot = 0.5 * np.column_stack(
        [
            -qx * wx - qy * wy - qz * wz,
            qw * wx + qy * wz - qz * wy,
            qw * wy + qz * wx - qx * wz,
            qw * wz + qx * wy - qy * wx,
        ]
    )
    # The Euler equations in the principal ratios, not the filter's parameters: J_xx = 1.
    ry, rz = nav.ratios_from_parameters(k.T)
    w_dot = np.column_stack(
        [(ry - rz) * wy * wz, (rz - 1.0) / ry * wz * wx, (1.0 - ry) / rz * wx * wy]
    )
    return np.hstack([v, a, q_dot, w_dot])


def simulate_truth(x0, k, duration_s, rng):
    """The truths sampled at every fix: (times (k,), states (runs, k, 13))."""
    steps_per_fix = round(FIX_PERIOD_S / TRUTH_STEP_S)
    fixes = round(duration_s / FIX_PERIOD_S) + 1
    x = x0.copy()
    out = np.empty((x.shape[0], fixes, 13))
    out[:, 0] = x
    h = TRUTH_STEP_S
    for fix in range(1, fixes):
        for _ in range(steps_per_fix):
            k1 = _rates(x, k)
            k2 = _rates(x + 0.5 * h * k1, k)
            k3 = _rates(x + 0.5 * h * k2, k)
            k4 = _rates(x + h * k3, k)
            x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
            x[:, 3:6] += NOISE.acceleration * np.sqrt(h) * rng.standard_normal((len(x), 3))
            x[:, 10:13] += NOISE.torque * np.sqrt(h) * rng.standard_normal((len(x), 3))
            x[:, 6:10] /= np.linalg.norm(x[:, 6:10], axis=1, keepdims=True)
        out[:, fix] = x
    return np.arange(fixes) * FIX_PERIOD_S, out


def measure(t, truth, rng, sigma_attitude=SIGMA_ATTITUDE_RAD) -> nav.PoseMeasurement:
    sp = position_sigma(truth[0:3])
    noise_q = rotation_vector_quaternion(sigma_attitude * rng.standard_normal(3))
    return nav.PoseMeasurement(
        t=t,
        p_LC_L=truth[0:3] + sp * rng.standard_normal(3),
        q_IT=quaternion_product(truth[6:10], noise_q),
        sigma_position_m=sp,
        sigma_attitude_rad=sigma_attitude,
    )


def random_attitudes(rng, count):
    q = rng.standard_normal((count, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def physical_parameters(rng, count):
    """Inertia parameters drawn from the filter's prior, kept where they are a rigid body's
    (|p_x|, |p_y|, |p_z| < 0.95): the truths of a consistency test come from the prior the
    filter is told (the rejection trims its tails beyond ~3 sigma)."""
    kept = []
    while len(kept) < count:
        k = np.array(PRIOR.parameters) + PRIOR.sigma * rng.standard_normal(2)
        if max(abs(k[0]), abs(k[1]), abs(nav.z_parameter(k))) < 0.95:
            kept.append(k)
    return np.array(kept)


def starts(rng, count, spin: str):
    """Initial truths: ~20 m behind the target on V-bar, drifting slowly; a principal-axis spin
    about z (3-6 deg/s) or a 3-D tumble (2-5 deg/s on every axis)."""
    x0 = np.zeros((count, 13))
    x0[:, 0:3] = [0.0, -20.0, 0.0] + rng.standard_normal((count, 3))
    x0[:, 3:6] = 0.01 * rng.standard_normal((count, 3))
    x0[:, 6:10] = random_attitudes(rng, count)
    if spin == "principal":
        x0[:, 12] = np.radians(rng.uniform(3.0, 6.0, count))
    else:
        signs = rng.choice([-1.0, 1.0], (count, 3))
        x0[:, 10:13] = signs * np.radians(rng.uniform(2.0, 5.0, (count, 3)))
    return x0


def wrong_pose(fix, rng) -> nav.PoseMeasurement:
    """An outlier: the fix 2 m off in a random direction and turned 30 deg about T's x."""
    direction = random_attitudes(rng, 1)[0, 1:]
    turn = rotation_vector_quaternion(np.radians(30.0) * np.array([1.0, 0.0, 0.0]))
    return nav.PoseMeasurement(
        fix.t,
        fix.p_LC_L + 2.0 * direction / np.linalg.norm(direction),
        quaternion_product(fix.q_IT, turn),
        fix.sigma_position_m,
        fix.sigma_attitude_rad,
    )


def fly_filter(times, truth, k_truth, rng, outliers=0.0, dropout=None, settings=SETTINGS):
    """One run of the filter on one truth (k, 13): per fix from the second on, (NEES, NIS or
    NaN, accepted, outlier, the error (14), the covariance's diagonal (14)); and the filter."""
    navigation = nav.RelativeNavigationFilter(N_RAD_S, settings)
    records = []
    for t, x in zip(times, truth):
        fix, outlier = measure(t, x, rng), False
        if dropout is not None and dropout[0] <= t < dropout[1]:
            fix = None
        elif rng.random() < outliers:
            fix, outlier = wrong_pose(fix, rng), True
        started = navigation.state is not None
        result = navigation.step(t, fix)
        if not started:
            continue  # the first two fixes start it
        value, error = nav.nees(navigation.state, x[0:3], x[3:6], x[6:10], x[10:13], k_truth)
        nis = result.nis if result is not None else np.nan
        accepted = result.accepted if result is not None else False
        records.append((value, nis, accepted, outlier, error, np.diag(navigation.state.P).copy()))
    return records, navigation


def monte_carlo(spin: str, runs: int, duration_s: float, seed: int):
    rng = np.random.default_rng(seed)
    k = physical_parameters(rng, runs)
    times, truths = simulate_truth(starts(rng, runs, spin), k, duration_s, rng)
    flights = [fly_filter(times, truths[i], k[i], rng)[0] for i in range(runs)]
    return times[2:], k, flights  # the first two fixes start the filter


def share_inside(values, dof, runs) -> float:
    """The share of samples whose Monte Carlo mean lies inside the two-sided 95 % bounds of
    chi2(runs * dof) / runs (Bar-Shalom et al., Sec. 5.4.2)."""
    low, high = chi2.ppf([0.025, 0.975], runs * dof) / runs
    mean = np.mean(values, axis=0)
    return float(np.mean((mean >= low) & (mean <= high)))


CONVERGED_AFTER_S = 60.0


@pytest.fixture(scope="module")
def flown():
    """spin -> (times, inertia parameters, flights): 50 runs of 150 s of each kind, flown once."""
    return {spin: monte_carlo(spin, runs=50, duration_s=150.0, seed=7) for spin in SPINS}


SPINS = ("principal", "tumble")


@pytest.mark.parametrize("spin", SPINS)
def test_nees_and_nis_are_consistent_over_50_runs(flown, spin):
    times, _, flights = flown[spin]
    after = times >= CONVERGED_AFTER_S
    nees = np.array([[r[0] for r in f] for f in flights])[:, after]
    nis = np.array([[r[1] for r in f] for f in flights])[:, after]
    assert share_inside(nees, nav.ERROR_SIZE, len(flights)) >= 0.90
    assert share_inside(nis, nav.MEASUREMENT_SIZE, len(flights)) >= 0.90
    # Position error inside 3 sigma of its own covariance on 99 % of samples.
    errors = np.array([[r[4][0:3] for r in f] for f in flights])
    sigmas = np.sqrt(np.array([[r[5][0:3] for r in f] for f in flights]))
    assert np.mean(np.abs(errors) <= 3 * sigmas) >= 0.99


def test_the_inertia_parameters_and_the_ratios_are_one_body():
    """p_x + p_y + p_z + p_x p_y p_z = 0 for any inertia; ratios -> parameters -> ratios."""
    rng = np.random.default_rng(1)
    for _ in range(100):
        J = np.sort(rng.uniform(1.0, 5.0, 3))
        J[rng.permutation(3)] = J.copy()
        if not J.max() < J.sum() - J.max():
            continue
        ratios = J[1:] / J[0]
        k = nav.parameters_from_ratios(ratios)
        pz = (J[0] - J[1]) / J[2]
        assert nav.z_parameter(k) == pytest.approx(pz, abs=1e-12)
        np.testing.assert_allclose(nav.ratios_from_parameters(k), ratios, rtol=1e-12)


def test_the_euler_jacobians_equal_finite_differences():
    rng = np.random.default_rng(2)
    w, k = rng.normal(0.0, 0.1, 3), rng.uniform(-0.5, 0.5, 2)
    A, B = nav.euler_jacobians(w, k)
    step = 1e-7
    A_fd = np.column_stack(
        [
            (nav.euler_rate(w + step * e, k) - nav.euler_rate(w - step * e, k)) / (2 * step)
            for e in np.eye(3)
        ]
    )
    B_fd = np.column_stack(
        [
            (nav.euler_rate(w, k + step * e) - nav.euler_rate(w, k - step * e)) / (2 * step)
            for e in np.eye(2)
        ]
    )
    np.testing.assert_allclose(A, A_fd, atol=1e-10)
    np.testing.assert_allclose(B, B_fd, atol=1e-10)


def test_on_a_3d_tumble_the_inertia_ratios_are_within_5_percent_by_120_s(flown):
    times, k, flights = flown["tumble"]
    at_120_s = int(np.searchsorted(times, 120.0))
    for k_truth, flight in zip(k, flights):
        k_estimate = k_truth - flight[at_120_s][4][12:14]  # the error is truth - estimate
        ratios, truth = nav.ratios_from_parameters(k_estimate), nav.ratios_from_parameters(k_truth)
        assert np.max(np.abs(ratios / truth - 1.0)) < 0.05, (ratios, truth)


def test_on_a_principal_axis_spin_the_inertia_is_reported_unobservable(flown):
    """Spinning about a principal axis, w_dot = 0 whatever the inertia: neither parameter is
    observable. The filter keeps their uncertainty near the prior's (it does not converge to a
    wrong value with a small sigma), and their errors stay inside it."""
    _, _, flights = flown["principal"]
    for flight in flights:
        sigma = np.sqrt(flight[-1][5][12:14])
        assert np.all(sigma > 0.7 * PRIOR.sigma), sigma
    errors = np.array([f[-1][4][12:14] for f in flights])
    assert np.mean(np.abs(errors) <= 3 * PRIOR.sigma) >= 0.95


def test_outliers_at_1_percent_are_rejected_without_divergence():
    rng = np.random.default_rng(17)
    k = physical_parameters(rng, 5)
    times, truths = simulate_truth(starts(rng, 5, "tumble"), k, 150.0, rng)
    outliers = 0
    for i in range(5):
        records, navigation = fly_filter(times, truths[i], k[i], rng, outliers=0.01)
        outlier = np.array([r[3] for r in records])
        outliers += outlier.sum()
        assert navigation.rejected >= outlier.sum()
        accepted = np.array([r[2] for r in records])
        assert not np.any(accepted & outlier)  # every outlier rejected
        assert np.mean(accepted[~outlier]) >= 0.99  # the good fixes used
        error, sigma = records[-1][4], np.sqrt(records[-1][5])
        assert np.all(np.abs(error) <= 4.0 * sigma), np.abs(error) / sigma
    assert outliers >= 5  # 5 runs of 300 fixes at 1 %: ~15


def test_a_10_s_dropout_is_recovered():
    """No fix from 60 s to 70 s: the covariance grows and covers the error; 10 s after the
    fixes return, the errors are back inside 3 sigma and the position sigma at its floor."""
    rng = np.random.default_rng(19)
    k = physical_parameters(rng, 5)
    times, truths = simulate_truth(starts(rng, 5, "tumble"), k, 100.0, rng)
    for i in range(5):
        records, _ = fly_filter(times, truths[i], k[i], rng, dropout=(60.0, 70.0))
        t = times[-len(records) :]
        during = (t >= 60.0) & (t < 70.0)
        sigma = np.sqrt(np.array([r[5] for r in records]))
        error = np.array([r[4] for r in records])
        assert np.all(np.abs(error[during]) <= 4.0 * sigma[during])
        before, after = sigma[np.searchsorted(t, 59.9), 0:3], sigma[np.searchsorted(t, 80.0), 0:3]
        assert np.all(sigma[np.searchsorted(t, 69.9), 0:3] > before)  # it grew in the gap
        np.testing.assert_allclose(after, before, rtol=0.5)  # and came back down
        assert np.all(np.abs(error[-1]) <= 3.0 * sigma[-1])


def test_the_float_process_model_is_the_shared_laws():
    rng = np.random.default_rng(3)
    for _ in range(20):
        x = rng.standard_normal(15)
        x[6:10] /= np.linalg.norm(x[6:10])
        x[13:15] *= 0.3
        a_L = rng.standard_normal(3)
        np.testing.assert_allclose(
            nav._rates_list(N_RAD_S, x.tolist(), a_L),
            nav.rates_reference(N_RAD_S, x, a_L),
            atol=1e-15,
        )


def test_the_nominal_alone_is_carried_as_predict_carries_it():
    rng = np.random.default_rng(5)
    truth = np.concatenate(
        [[3.0, -20.0, 1.0, 0.01, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.05, 0.02, 0.1]]
    )
    state = nav.initial_state(measure(0.0, truth, rng), measure(0.5, truth, rng), PRIOR)
    state.inertia_parameters = np.array([0.2, -0.3])
    full = nav.predict(state, 3.2, N_RAD_S, NOISE, (1e-3, 0.0, -2e-3), 0.25, 10.0)
    nominal = nav.propagate_nominal(state, 3.2, N_RAD_S, (1e-3, 0.0, -2e-3), 0.25)
    np.testing.assert_allclose(nav.nominal_vector(nominal), nav.nominal_vector(full), atol=1e-12)
    np.testing.assert_array_equal(nominal.P, state.P)  # the covariance is left as it was


@pytest.mark.parametrize("dof", [3, 6, 12])
@pytest.mark.parametrize("probability", [0.025, 0.5, 0.975, 0.9999])
def test_the_chi_square_quantile_is_scipy_stats(dof, probability):
    assert nav.chi_square_quantile(probability, dof) == pytest.approx(
        chi2.ppf(probability, dof), rel=1e-10
    )


def _converged_state():
    return nav.FilterState(
        t=0.0,
        p_LC_L=np.array([100.0, -800.0, 50.0]),
        v_LC_L=np.array([0.1, 0.0, -0.05]),
        q_IT=np.array([1.0, 0.0, 0.0, 0.0]),
        w_IT_T=np.radians([1.0, 0.5, 2.0]),
        inertia_parameters=np.array([0.2, -0.3]),
        P=np.diag([0.05] * 3 + [1e-6] * 3 + [1e-4] * 3 + [1e-8] * 3 + [1e-5] * 2),
    )


@pytest.mark.parametrize(
    ("position_off_m", "attitude_off_deg", "parts"),
    [
        (0.0, 40.0, ("rotation",)),  # the tumble's model failed; the translation is fine
        (60.0, 0.0, ("translation",)),  # an untold manoeuvre; the tumble is fine
        (60.0, 40.0, ("translation", "rotation")),
    ],
)
def test_a_diverged_filter_resets_only_the_part_that_diverged(
    position_off_m, attitude_off_deg, parts
):
    state = _converged_state()
    fix = nav.PoseMeasurement(
        0.0,
        state.p_LC_L + position_off_m / np.sqrt(3.0),
        quaternion_product(
            state.q_IT, rotation_vector_quaternion(np.radians([attitude_off_deg, 0, 0]))
        ),
        8.0,
        np.radians(2.0),
    )
    reset, which = nav.reset_diverged(state, fix, 0.5, PRIOR, 0.9999)
    assert which == parts
    kept_translation = "translation" not in parts
    assert np.array_equal(reset.v_LC_L, state.v_LC_L)  # rates and velocity are kept, always
    assert np.array_equal(reset.w_IT_T, state.w_IT_T)
    np.testing.assert_array_equal(
        reset.P[0:6, 0:6] == state.P[0:6, 0:6],
        np.full((6, 6), kept_translation) | (state.P[0:6, 0:6] == 0.0) & (reset.P[0:6, 0:6] == 0.0),
    )
    if "rotation" in parts:
        np.testing.assert_array_equal(reset.q_IT, fix.q_IT)
        assert reset.P[9, 9] == pytest.approx(2.0 * np.radians(2.0) ** 2 / 0.5**2)
        assert reset.P[12, 12] >= PRIOR.sigma**2
    assert np.all(np.linalg.eigvalsh(reset.P) > 0.0)
