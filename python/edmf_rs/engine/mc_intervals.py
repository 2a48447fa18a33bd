"""Threshold bounds from Monte Carlo samples of U_c that hold their probability.

Eq. 5 asks for the shortest interval holding the per-sensor probability p.
From N samples, the interval between the order statistics x_(i) and x_(i+k)
holds a probability distributed as Beta(k, N - k + 1) whatever the
distribution (David & Nagaraja, *Order Statistics*, 2003, Sec. 2.5), so

    P(coverage >= p) = P(Binom(N, p) <= k - 1).

The plain estimator (the shortest window of ceil(pN) samples) holds p only on
average, and less once the shortest window is chosen among many. Here k is
the smallest count with ``P(coverage >= p) >= confidence``, so each sensor's
interval holds at least p with the stated confidence:

- *central* (U_c symmetric about its mean, every source symmetric): the
  equal-tailed window ``i = (N - 1 - k) // 2``; its coverage is exactly
  Beta(k, N - k + 1);
- *shortest* (otherwise): the window of k gaps whose width, smoothed over
  neighbouring windows, is least; smoothing keeps the choice from chasing
  the sampling noise of single spacings (the source of the plain
  estimator's narrow bias).

Each bound's Monte Carlo standard error comes from the order-statistic
interval ``x_(r +- sqrt(N q (1 - q)))`` (central) or from a Poisson bootstrap
of the whole estimator (shortest, whose window position also varies).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy import stats

#: Probability that a sensor's Monte Carlo interval holds at least its target.
DEFAULT_CONFIDENCE = 0.975
#: Fewer samples than this in a tail and the bound rests on a handful of draws.
MIN_TAIL = 100
_BOOTSTRAP = 50


@dataclass(frozen=True)
class SampleInterval:
    """One sensor's bounds from its samples, their Monte Carlo standard errors,
    the estimator (``"central"`` or ``"shortest"``) and the samples in each tail."""

    low: float
    high: float
    se_low: float
    se_high: float
    method: str
    lower_tail: int
    upper_tail: int


def window_span(n: int, probability: float, confidence: float = DEFAULT_CONFIDENCE) -> int:
    """Gaps k between the order statistics bounding the interval, so that
    ``P(Beta(k, n - k + 1) >= probability) >= confidence``.

    Examples
    --------
    >>> window_span(200_000, 0.99, 0.5) >= 0.99 * 200_000
    True
    """
    return int(stats.binom.ppf(confidence, n, probability)) + 1


def samples_needed(probability: float, confidence: float = DEFAULT_CONFIDENCE, tail: int = 0) -> int:
    """The fewest samples giving a window with ``tail`` expected samples in each tail
    (``tail = 0``: just an interval inside the samples' range).

    Examples
    --------
    >>> samples_needed(0.9, 0.5) <= 20
    True
    """
    if tail:
        return int(math.ceil(2 * tail / (1.0 - probability)))

    def ok(n: int) -> bool:  # P(Binom(n, p) <= n - 2) >= confidence
        return 1.0 - probability**n - n * probability ** (n - 1) * (1.0 - probability) >= confidence

    hi = 2
    while not ok(hi):
        hi *= 2
    lo = hi // 2
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


def _too_few(n: int, probability: float, confidence: float) -> ValueError:
    needed = samples_needed(probability, confidence)
    return ValueError(
        f"combined: {n} Monte Carlo samples cannot bound a per-sensor probability of {probability} with "
        f"confidence {confidence}; at least {needed} samples are needed"
    )


def _order_se(x: np.ndarray, r: int) -> float:
    """Half the order-statistic interval ``x_(r +- sqrt(N q (1 - q)))``: the SE of the quantile."""
    n = x.shape[0]
    q = (r + 0.5) / n
    s = max(1, int(round(math.sqrt(n * q * (1.0 - q)))))
    return 0.5 * float(x[min(r + s, n - 1)] - x[max(r - s, 0)])


def _shortest_start(lower: np.ndarray, upper: np.ndarray) -> int:
    """Start i of the window ``[lower[i], upper[i]]`` of least smoothed width (ties: the lowest).

    ``lower = x[0 : T + 1]`` and ``upper = x[k : k + T + 1]`` for sorted x with
    T samples outside the window. Widths are averaged over +-T/20 neighbouring
    windows (fewer at the ends) before the minimum is taken.
    """
    widths = upper - lower
    m = widths.shape[0]
    half = max(1, m // 20)
    csum = np.concatenate(([0.0], np.cumsum(widths)))
    idx = np.arange(m)
    lo = np.maximum(idx - half, 0)
    hi = np.minimum(idx + half + 1, m)
    return int(np.argmin((csum[hi] - csum[lo]) / (hi - lo)))


def _bootstrap_se(x: np.ndarray, probability: float, confidence: float, rng) -> tuple[float, float]:
    """Poisson-bootstrap SE of the shortest window's bounds.

    Only the samples near the two tails matter, so each of the ``a`` lowest and
    ``a`` highest samples gets its own Poisson(1) count and the middle one
    Poisson(n - 2a) total: O(tail) work per replicate instead of O(n).
    """
    n = x.shape[0]
    outside = n - 1 - window_span(n, probability, confidence)
    a = min(n // 2, 2 * (outside + 1) + 100)
    count_low = rng.poisson(1.0, (_BOOTSTRAP, a))
    count_high = rng.poisson(1.0, (_BOOTSTRAP, a))
    middle = rng.poisson(n - 2 * a, _BOOTSTRAP) if n > 2 * a else np.zeros(_BOOTSTRAP, dtype=np.int64)
    n_low, n_high = count_low.sum(axis=1), count_high.sum(axis=1)
    nb = n_low + middle + n_high
    kb = (stats.binom.ppf(confidence, nb, probability) + 1).astype(np.int64)  # window_span, vectorised
    lows, highs = [], []
    for b in range(_BOOTSTRAP):
        tb = int(nb[b] - 1 - kb[b])
        first_up = int(kb[b] - (n_low[b] + middle[b]))  # index in `high` of the first window's top
        if tb < 0 or tb >= n_low[b] or first_up < 0 or first_up + tb >= n_high[b]:
            continue
        low = np.repeat(x[:a], count_low[b])
        high = np.repeat(x[n - a:], count_high[b])
        i = _shortest_start(low[: tb + 1], high[first_up:first_up + tb + 1])
        lows.append(low[i])
        highs.append(high[first_up + i])
    if len(lows) < 2:
        return math.inf, math.inf
    return float(np.std(lows, ddof=1)), float(np.std(highs, ddof=1))


def sample_interval(sorted_samples: np.ndarray, probability: float, *, symmetric: bool = False,
                    confidence: float = DEFAULT_CONFIDENCE, rng=None) -> SampleInterval:
    """Bounds holding ``probability`` with ``confidence`` from one sensor's sorted samples.

    Parameters
    ----------
    sorted_samples : 1-D float array, ascending
    probability : per-sensor probability p in (0, 1)
    symmetric : U_c is symmetric about its mean: take the equal-tailed window
    confidence : probability that the interval holds at least p
    rng : numpy Generator for the bootstrap SE of the shortest window (default: seed 0)

    Returns
    -------
    SampleInterval

    Raises
    ------
    ValueError
        Too few samples for the window to fit inside them (the message says how many are needed).

    Examples
    --------
    >>> x = np.sort(np.random.default_rng(0).normal(size=20_000))
    >>> b = sample_interval(x, 0.9, symmetric=True)
    >>> bool(-1.70 < b.low < -1.60 and 1.60 < b.high < 1.70)
    True
    """
    x = sorted_samples
    n = x.shape[0]
    k = window_span(n, probability, confidence)
    if k > n - 1:
        raise _too_few(n, probability, confidence)
    if symmetric:
        i = (n - 1 - k) // 2
        return SampleInterval(float(x[i]), float(x[i + k]), _order_se(x, i), _order_se(x, i + k),
                              "central", i, n - 1 - i - k)
    t = n - 1 - k
    i = _shortest_start(x[: t + 1], x[k:])
    se_low, se_high = _bootstrap_se(x, probability, confidence, np.random.default_rng(0) if rng is None else rng)
    return SampleInterval(float(x[i]), float(x[i + k]), se_low, se_high, "shortest", i, t - i)


def warn_thin_tails(names, probability: float, n_samples: int, confidence: float = DEFAULT_CONFIDENCE,
                    stacklevel: int = 3) -> None:
    """UserWarning naming the Monte Carlo sensors whose tails hold fewer than
    :data:`MIN_TAIL` samples on average, with the sample count that would suffice."""
    names = list(names)
    expected = 0.5 * n_samples * (1.0 - probability)
    if not names or expected >= MIN_TAIL:
        return
    shown = ", ".join(map(str, names[:5])) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
    suggest = samples_needed(probability, confidence, tail=MIN_TAIL)
    warnings.warn(
        f"combined: sensor {shown}: about {expected:.0f} of {n_samples:,} Monte Carlo samples fall in each tail "
        f"beyond the per-sensor probability {probability:.6g}, so the threshold bounds rest on few draws; "
        f"use n_samples >= {suggest:,} (>= {MIN_TAIL} per tail)",
        UserWarning, stacklevel=stacklevel,
    )
