"""Wilson intervals against published values and the binomial coverage they promise."""

import math

import numpy as np
import pytest
from scipy.stats import binom

from rpod.models.statistics import SuccessShare, wilson_interval


def test_known_values():
    # Brown, Cai and DasGupta (2001), and the closed form by hand: 0/10 -> (0, 0.2775),
    # 10/10 -> (0.7225, 1), 5/10 -> (0.2366, 0.7634) at 95 %.
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.27753), abs=1e-5)
    assert wilson_interval(10, 10) == pytest.approx((0.72247, 1.0), abs=1e-5)
    assert wilson_interval(5, 10) == pytest.approx((0.23659, 0.76341), abs=1e-5)
    low, high = wilson_interval(350, 2686)
    assert low < 350 / 2686 < high and high - low < 0.03


def test_interval_is_inside_zero_one_and_contains_the_share():
    for n in (1, 2, 7, 50, 1000):
        for k in range(0, n + 1, max(1, n // 7)):
            low, high = wilson_interval(k, n)
            assert 0.0 <= low <= k / n <= high <= 1.0


def test_coverage_is_near_nominal():
    # Exact coverage at n = 50 over a grid of true p: Wilson stays within a few points of 95 %
    # on average (the Wald interval drops to ~0.6 near p = 0.02).
    n = 50
    bounds = np.array([wilson_interval(k, n) for k in range(n + 1)])
    coverages = []
    for p in np.linspace(0.02, 0.98, 49):
        covered = (bounds[:, 0] <= p) & (p <= bounds[:, 1])
        coverages.append(binom.pmf(np.arange(n + 1), n, p)[covered].sum())
    assert 0.93 < np.mean(coverages) < 0.97
    assert min(coverages) > 0.80


def test_bad_input_is_an_error():
    for args in ((1, 0), (-1, 5), (6, 5)):
        with pytest.raises(ValueError):
            wilson_interval(*args)
    with pytest.raises(ValueError):
        wilson_interval(1, 2, confidence=1.0)


def test_share_text():
    assert SuccessShare(350, 2686).percent_text() == "13.0 % (350/2686; 95 % CI 11.8-14.4 %)"
    assert SuccessShare(0, 0).percent_text() == "no runs judged"
    assert math.isnan(SuccessShare(0, 0).share)
