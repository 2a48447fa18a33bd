"""Rectangular versus ellipsoidal threshold bounds (Sec. 3.2, Fig. 3).

Draws of a bivariate standard normal with a *true* correlation are tested
against two regions meant to hold ``phi`` of them:

- the ellipse D_M^2 <= chi2_phi(2) (Eq. 9, 10), built with an *assumed*
  correlation; it holds ``phi`` only when the assumption is right;
- the Sidak rectangle of the EDMF thresholds (Eq. 6, 11), which holds at
  least ``phi`` whatever the correlation (Eq. 7).

The rectangle is counted by EDMF itself: each draw is a "model instance"
whose residual against zero measurements is the draw (Eq. 8).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from .. import _core
from ..engine._validate import positive_int, probability
from ..engine.falsify import falsify
from ..engine.thresholds import Thresholds, threshold_bounds

#: Fig. 3: the assumed correlation and the true ones of panels a), b), c).
PAPER_RHO_ASSUMED = 0.9
PAPER_RHO_TRUE = (0.9, 0.4, -0.9)
#: Share of draws inside the ellipse reported in Sec. 3.2 (P_T >= 0.95 in all three).
PAPER_P_M = (0.95, 0.64, 0.42)
PAPER_N_DRAWS = 1000


@dataclass(frozen=True, eq=False)
class CoverageResult:
    """Draws (n_draws, 2) and which of them each region holds, as returned by `coverage`.

    Attributes
    ----------
    rho_true, rho_assumed : float
        The correlation of the draws, and the one the ellipse assumes.
    phi : float
        The probability both regions are meant to hold.
    draws : numpy.ndarray
        (n_draws, 2) draws of the bivariate standard normal.
    inside_ellipse, inside_rectangle : numpy.ndarray
        Boolean (n_draws,): which draws each region holds.
    chi2_bound : float
        The squared-Mahalanobis radius of the ellipse.
    thresholds : Thresholds
        The rectangle's per-axis bounds.
    P_M, P_T : float
        Share of the draws inside the ellipse (Eq. 10) and the rectangle (Eq. 11).

    Examples
    --------
    >>> from edmf_rs.paper import coverage
    >>> r = coverage.coverage(-0.9, n_draws=2000, seed=0)
    >>> r.P_T >= 0.94, r.P_M < 0.6
    (True, True)
    """

    rho_true: float
    rho_assumed: float
    phi: float
    draws: np.ndarray
    inside_ellipse: np.ndarray
    inside_rectangle: np.ndarray
    chi2_bound: float
    thresholds: Thresholds

    @property
    def P_M(self) -> float:  # noqa: N802 - the paper's symbol (Eq. 10)
        return float(self.inside_ellipse.mean())

    @property
    def P_T(self) -> float:  # noqa: N802 - the paper's symbol (Eq. 11)
        return float(self.inside_rectangle.mean())


def _correlation(rho, name: str) -> float:
    if isinstance(rho, bool) or not isinstance(rho, (int, float, np.floating, np.integer)):
        raise TypeError(f"{name}: expected a number in (-1, 1), got {type(rho).__name__}")
    rho = float(rho)
    if not -1.0 < rho < 1.0:
        raise ValueError(f"{name}: expected a correlation in (-1, 1), got {rho}")
    return rho


def correlation_matrix(rho: float) -> np.ndarray:
    """The 2 x 2 correlation matrix [[1, rho], [rho, 1]].

    Parameters
    ----------
    rho : float
        The correlation.

    Returns
    -------
    numpy.ndarray

    Examples
    --------
    >>> from edmf_rs.paper import coverage
    >>> coverage.correlation_matrix(0.5).tolist()
    [[1.0, 0.5], [0.5, 1.0]]
    """
    return np.array([[1.0, rho], [rho, 1.0]])


def coverage(rho_true: float, rho_assumed: float = PAPER_RHO_ASSUMED, *, phi: float = 0.95,
             n_draws: int = PAPER_N_DRAWS, seed=None) -> CoverageResult:
    """P_M (Eq. 10) and P_T (Eq. 11) for draws of N(0, [[1, rho_true], [rho_true, 1]]).

    The ellipse D_M^2 <= chi2_phi(2) (Eq. 9) uses ``rho_assumed``; the
    rectangle is the Sidak threshold bounds of the two N(0, 1) marginals
    (Eq. 6), counted by `edmf_rs.falsify` itself (Eq. 8).

    Parameters
    ----------
    rho_true : float
        Correlation of the draws, in (-1, 1).
    rho_assumed : float, default 0.9
        Correlation the ellipse assumes, in (-1, 1).
    phi : float, default 0.95
        Probability both regions are meant to hold.
    n_draws : int, default 1000
        Number of draws.
    seed : int, numpy.random.Generator or None
        Seed of the draws.

    Returns
    -------
    CoverageResult

    Raises
    ------
    TypeError
        If a correlation is not a number.
    ValueError
        If a correlation is not in (-1, 1), ``phi`` not in (0, 1) or
        ``n_draws`` not positive.

    Examples
    --------
    >>> from edmf_rs.paper import coverage
    >>> r = coverage.coverage(0.9, n_draws=2000, seed=0)
    >>> abs(r.P_M - 0.95) < 0.02, r.P_T >= 0.94
    (True, True)
    """
    rho_true = _correlation(rho_true, "rho_true")
    rho_assumed = _correlation(rho_assumed, "rho_assumed")
    phi = probability(phi, "phi")
    n_draws = positive_int(n_draws, "n_draws")
    rng = np.random.default_rng(seed)
    chol = np.linalg.cholesky(correlation_matrix(rho_true))
    draws = np.ascontiguousarray(rng.standard_normal((n_draws, 2)) @ chol.T)

    mean = np.zeros(2)
    d2 = _core.mahalanobis_squared(draws, mean, correlation_matrix(rho_assumed))  # Eq. 9
    bound = float(stats.chi2.ppf(phi, df=2))
    inside_ellipse = d2 <= bound  # Eq. 10

    # Each marginal is exactly N(0, 1), whatever the correlation: Eq. 6 on it.
    thresholds = threshold_bounds(stats.norm(loc=mean, scale=np.ones(2)), phi=phi, correction="sidak")
    inside_rectangle = falsify(draws, mean, thresholds, diagnostics=False).candidate_mask  # Eq. 11
    return CoverageResult(rho_true, rho_assumed, phi, draws, inside_ellipse,
                          np.asarray(inside_rectangle), bound, thresholds)


def figure3_cases(*, n_draws: int = PAPER_N_DRAWS, seed=0, phi: float = 0.95,
                  rho_assumed: float = PAPER_RHO_ASSUMED,
                  rho_true=PAPER_RHO_TRUE) -> tuple[CoverageResult, ...]:
    """The three panels of Fig. 3, each from its own stream of the seed.

    Parameters
    ----------
    n_draws : int, default 1000
        Draws per panel.
    seed : int, default 0
        Seed; each panel gets its own stream of it.
    phi : float, default 0.95
        Probability both regions are meant to hold.
    rho_assumed : float, default 0.9
        Correlation the ellipse assumes.
    rho_true : tuple of float, default (0.9, 0.4, -0.9)
        The true correlations of the panels.

    Returns
    -------
    tuple of CoverageResult

    Raises
    ------
    ValueError
        As `coverage`.

    Examples
    --------
    >>> from edmf_rs.paper import coverage
    >>> [round(r.P_M, 2) for r in coverage.figure3_cases()]
    [0.95, 0.65, 0.42]
    """
    streams = np.random.SeedSequence(seed).spawn(len(rho_true))
    return tuple(coverage(r, rho_assumed, phi=phi, n_draws=n_draws, seed=np.random.default_rng(s))
                 for r, s in zip(rho_true, streams))
