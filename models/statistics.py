"""Statistics of campaign outcomes: the share of successes and its confidence interval.

Owns: `wilson_interval` (the Wilson score interval of a binomial proportion) and
`SuccessShare`, the one way rpod states a success rate ("13.0 % (350/2686; 95 % CI
11.8-14.4 %)") in `rpod report`, the results files and the README.
Does not own: what counts as a success (each run's `mission.success`, judged by simulate and
the controller's plug-in).

Why Wilson: the normal ("Wald") interval p +- z sqrt(p (1 - p) / n) collapses to zero width at
0 or n successes and leaves [0, 1] near them, exactly where campaign rates live (49/50, 0/20).
Wilson's interval (E. B. Wilson, JASA 22 (1927) 209-212) inverts the score test,

    centre = (p + z^2 / 2n) / (1 + z^2 / n),
    half   = z / (1 + z^2 / n) * sqrt(p (1 - p) / n + z^2 / 4n^2),

stays inside [0, 1], and covers close to its nominal level even for small n (Brown, Cai and
DasGupta, Statist. Sci. 16 (2001) 101-133, recommend it for n < 40 and beyond).
"""

import dataclasses
import math


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval (low, high) of a proportion, both in [0, 1].

    Args:
        successes: the number of successes k, 0 <= k <= n.
        n: the number of trials (> 0).
        confidence: the two-sided confidence level, in (0, 1).

    Raises:
        ValueError: n < 1, k outside [0, n], or confidence outside (0, 1).
    """
    if n < 1 or not 0 <= successes <= n:
        raise ValueError(f"need 0 <= successes <= n and n >= 1, got {successes} of {n}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    from scipy.stats import norm  # here: scipy.stats costs ~0.35 s to import, every command

    z = float(norm.ppf(0.5 + confidence / 2.0))
    p = successes / n
    scale = 1.0 + z * z / n
    centre = (p + z * z / (2.0 * n)) / scale
    half = z / scale * math.sqrt(p * (1.0 - p) / n + z * z / (4.0 * n * n))
    # At k = 0 (k = n) the low (high) end is exactly 0 (1); round-off must not move it.
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == n else min(1.0, centre + half)
    return low, high


@dataclasses.dataclass(frozen=True)
class SuccessShare:
    """k successes out of n, with the Wilson interval at `confidence`.

    Attributes:
        successes: k.
        n: the number of runs judged (runs with no verdict are not counted).
        confidence: the interval's level (0.95 unless stated).
    """

    successes: int
    n: int
    confidence: float = 0.95

    @property
    def share(self) -> float:
        """k / n (nan when n is 0)."""
        return self.successes / self.n if self.n else math.nan

    @property
    def interval(self) -> tuple[float, float]:
        """The Wilson interval (nan, nan when n is 0)."""
        if self.n == 0:
            return math.nan, math.nan
        return wilson_interval(self.successes, self.n, self.confidence)

    def percent_text(self) -> str:
        """E.g. '13.0 % (350/2686; 95 % CI 11.8-14.4 %)', or 'no runs judged'."""
        if self.n == 0:
            return "no runs judged"
        low, high = self.interval
        level = f"{100.0 * self.confidence:g}"
        return (
            f"{100.0 * self.share:.1f} % ({self.successes}/{self.n}; {level} % CI "
            f"{100.0 * low:.1f}-{100.0 * high:.1f} %)"
        )
