"""The two identification methods the paper compares EDMF with (Sec. 2 and 4.1).

Both work on a finite set of model instances: ``predictions`` has one row per
instance and one column per sensor, exactly as for `edmf_rs.falsify`.

- `least_squares`: weighted residual minimisation (Eq. 1 and 15), one
  optimal instance.
- `bayesian_posterior`: posterior weights of the instances under a
  prior and the Gaussian likelihood of Eq. 17, with the highest-posterior-
  density set holding a given mass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, special

from ..engine._validate import finite_vector, probability


@dataclass(frozen=True, eq=False)
class LeastSquaresResult:
    """Optimum of Eq. 15 over the instances, as returned by `least_squares`.

    Attributes
    ----------
    index : int
        The minimising instance (the first on ties).
    objective : numpy.ndarray
        eps_o^T W eps_o for every instance.
    weights : numpy.ndarray
        The diagonal of W.
    value : object
        The parameter value of ``index`` when ``parameters`` were given, else None.
    minimum : float
        The objective at ``index``.

    Examples
    --------
    >>> from edmf_rs.paper import baselines
    >>> r = baselines.least_squares([[1.0], [2.0], [3.0]], [2.2], weights="sigma", sigma=1.0)
    >>> r.index, round(r.minimum, 2)
    (1, 0.04)
    """

    index: int
    objective: np.ndarray
    weights: np.ndarray
    value: object = None

    @property
    def minimum(self) -> float:
        return float(self.objective[self.index])


@dataclass(frozen=True, eq=False)
class PosteriorResult:
    """Posterior over the instances (Eq. 2 with the likelihood of Eq. 17), as returned by `bayesian_posterior`.

    Attributes
    ----------
    posterior : numpy.ndarray
        Posterior probability of every instance; sums to one.
    log_likelihood : numpy.ndarray
        Log-likelihood of every instance, with the normalising constant of Eq. 17.
    hpd_mask : numpy.ndarray
        The highest-posterior-density set: instances taken by decreasing
        posterior (lower index first on ties) until their cumulative mass
        reaches ``mass``.
    mass : float
        Probability mass of that set.
    hpd_indices : numpy.ndarray
        Indices of the set.
    hpd_size : int
        Its size.
    map_index : int
        The most probable instance (maximum a posteriori).

    Examples
    --------
    >>> from edmf_rs.paper import baselines
    >>> r = baselines.bayesian_posterior([[1.0], [2.0], [3.0]], [2.0], covariance=[0.25])
    >>> r.map_index, r.hpd_indices.tolist(), round(float(r.posterior.sum()), 6)
    (1, [0, 1, 2], 1.0)
    """

    posterior: np.ndarray
    log_likelihood: np.ndarray
    hpd_mask: np.ndarray
    mass: float

    @property
    def hpd_indices(self) -> np.ndarray:
        return np.flatnonzero(self.hpd_mask)

    @property
    def hpd_size(self) -> int:
        return int(self.hpd_mask.sum())

    @property
    def map_index(self) -> int:
        """The most probable instance (maximum a posteriori)."""
        return int(np.argmax(self.posterior))


def _predictions(predictions, n_m: int | None = None) -> np.ndarray:
    try:
        g = np.asarray(predictions, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"predictions: expected a 2-D array of numbers ({exc})") from None
    if g.ndim != 2:
        raise ValueError(f"predictions: expected shape (instances, sensors), got shape {g.shape}")
    if g.shape[0] == 0:
        raise ValueError("predictions: expected at least one model instance, got 0 rows")
    if n_m is not None and g.shape[1] != n_m:
        raise ValueError(f"predictions: expected {n_m} columns (one per measurement), got shape {g.shape}")
    if not np.all(np.isfinite(g)):
        raise ValueError("predictions: expected finite values")
    return g


def _per_sensor(value, n_m: int, name: str) -> np.ndarray:
    """A scalar broadcast to the sensors, or a vector of n_m finite values."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected a number or one number per sensor ({exc})") from None
    return finite_vector(np.broadcast_to(arr, (n_m,)) if arr.ndim == 0 else arr, name, n=n_m)


def _parameters(parameters, n: int):
    if parameters is None:
        return None
    p = np.asarray(parameters)
    if p.shape[:1] != (n,):
        raise ValueError(f"parameters: expected one value per instance ({n}), got shape {p.shape}")
    return p


def least_squares(predictions, measurements, *, weights="measured", sigma=None,
                  parameters=None) -> LeastSquaresResult:
    """Weighted least squares over the instances (Eq. 15).

    ``weights`` picks the diagonal of W:

    - ``"measured"`` (default): W = diag(y)^-2, as in the paper (Sec. 4.1,
      after Mottershead et al.), i.e. relative residuals;
    - ``"sigma"``: W = diag(sigma)^-2 with ``sigma`` (scalar or per sensor);
    - an array of n_m non-negative weights (e.g. 1/sigma^2), used as given.

    Parameters
    ----------
    predictions : array_like
        g(theta), one row per instance, one column per sensor.
    measurements : array_like
        y, one per sensor.
    weights : {"measured", "sigma"} or array_like, default "measured"
        The diagonal of W, as above.
    sigma : float or array_like, optional
        Standard deviations, with ``weights="sigma"`` only.
    parameters : array_like, optional
        One parameter value (or row) per instance, to report the optimum's.

    Returns
    -------
    LeastSquaresResult

    Raises
    ------
    ValueError
        If a measured value is zero with ``weights="measured"``, ``sigma`` is
        missing or not positive, the weights are negative or all zero, or the
        shapes disagree.

    Examples
    --------
    >>> from edmf_rs.paper import baselines
    >>> r = baselines.least_squares([[1.0, 2.0], [2.0, 4.0]], [2.1, 3.9], parameters=[10.0, 20.0])
    >>> r.index, float(r.value)
    (1, 20.0)
    """
    y = finite_vector(measurements, "measurements")
    g = _predictions(predictions, y.shape[0])
    if isinstance(weights, str):
        if weights == "measured":
            if np.any(y == 0):
                raise ValueError("measurements: W = diag(y)^-2 needs non-zero measured values")
            w = 1.0 / y**2
        elif weights == "sigma":
            if sigma is None:
                raise ValueError('sigma: required with weights="sigma"')
            s = _per_sensor(sigma, y.shape[0], "sigma")
            if np.any(s <= 0):
                raise ValueError("sigma: expected positive standard deviations")
            w = 1.0 / s**2
        else:
            raise ValueError(f'weights: expected "measured", "sigma" or an array, got {weights!r}')
    else:
        if sigma is not None:
            raise ValueError('sigma: only used with weights="sigma"')
        w = _per_sensor(weights, y.shape[0], "weights")
        if np.any(w < 0) or not np.any(w > 0):
            raise ValueError("weights: expected non-negative weights, not all zero")
    residuals = g - y  # Eq. 14
    objective = (residuals**2) @ w  # Eq. 15 with a diagonal W
    index = int(np.argmin(objective))
    p = _parameters(parameters, g.shape[0])
    return LeastSquaresResult(index=index, objective=objective, weights=np.asarray(w),
                              value=None if p is None else p[index])


def _log_prior(prior, n: int) -> np.ndarray:
    if prior is None:
        return np.zeros(n)  # uniform prior over the instances (Eq. 16)
    w = np.asarray(prior, dtype=np.float64)
    if w.shape != (n,):
        raise ValueError(f"prior: expected one weight per instance ({n}), got shape {w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError("prior: expected finite non-negative weights")
    if not np.any(w > 0):
        raise ValueError("prior: expected at least one positive weight")
    with np.errstate(divide="ignore"):
        return np.log(w)


def gaussian_log_likelihood(residuals, covariance) -> np.ndarray:
    """log N(residuals; 0, covariance) for each row of ``residuals`` (Eq. 17).

    Parameters
    ----------
    residuals : array_like
        (N, n_m) residuals, one row per instance.
    covariance : array_like
        A vector of n_m variances (independent errors) or a full symmetric
        positive-definite (n_m, n_m) matrix (correlated errors).

    Returns
    -------
    numpy.ndarray
        (N,) log-densities.

    Raises
    ------
    TypeError
        If ``covariance`` is not numeric.
    ValueError
        If ``covariance`` has the wrong shape, is not finite, not positive
        (definite) or not symmetric.

    Examples
    --------
    >>> from edmf_rs.paper import baselines
    >>> baselines.gaussian_log_likelihood([[0.0]], [1.0]).round(4).tolist()
    [-0.9189]
    """
    r = np.asarray(residuals, dtype=np.float64)
    n_m = r.shape[1]
    try:
        cov = np.asarray(covariance, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"covariance: expected an array of numbers ({exc})") from None
    if not np.all(np.isfinite(cov)):
        raise ValueError("covariance: expected finite values")
    if cov.ndim == 1:
        if cov.shape != (n_m,):
            raise ValueError(f"covariance: expected {n_m} variances (one per sensor), got shape {cov.shape}")
        if np.any(cov <= 0):
            raise ValueError("covariance: expected positive variances")
        quad = (r**2) @ (1.0 / cov)
        logdet = float(np.sum(np.log(cov)))
    elif cov.ndim == 2:
        if cov.shape != (n_m, n_m):
            raise ValueError(f"covariance: expected shape ({n_m}, {n_m}), got {cov.shape}")
        if not np.allclose(cov, cov.T, rtol=1e-10, atol=0.0):
            raise ValueError("covariance: expected a symmetric matrix")
        try:
            chol, lower = linalg.cho_factor(cov, lower=True, check_finite=False)
        except linalg.LinAlgError:
            raise ValueError("covariance: expected a positive-definite matrix") from None
        z = linalg.solve_triangular(chol, r.T, lower=lower, check_finite=False)
        quad = np.sum(z**2, axis=0)
        logdet = 2.0 * float(np.sum(np.log(np.diag(chol))))
    else:
        raise ValueError(f"covariance: expected a vector of variances or a matrix, got shape {cov.shape}")
    return -0.5 * (quad + logdet + n_m * np.log(2.0 * np.pi))


def hpd_mask(posterior: np.ndarray, mass: float) -> np.ndarray:
    """Highest-posterior-density set: instances by decreasing posterior until
    the cumulative mass reaches ``mass`` (the one crossing it included).

    Parameters
    ----------
    posterior : numpy.ndarray
        Posterior probabilities of the instances, summing to one.
    mass : float
        Probability mass the set must hold.

    Returns
    -------
    numpy.ndarray
        Boolean mask of the set.

    Examples
    --------
    >>> import numpy as np
    >>> from edmf_rs.paper import baselines
    >>> baselines.hpd_mask(np.array([0.1, 0.6, 0.3]), 0.8).tolist()
    [False, True, True]
    """
    order = np.argsort(-posterior, kind="stable")
    cumulative = np.cumsum(posterior[order])
    # A tiny tolerance so that round-off in the sum never adds an extra instance.
    k = min(int(np.searchsorted(cumulative, mass - 1e-12, side="left")) + 1, posterior.size)
    mask = np.zeros(posterior.size, dtype=bool)
    mask[order[:k]] = True
    return mask


def bayesian_posterior(predictions, measurements, covariance, *, mean=0.0, prior=None,
                       mass: float = 0.95) -> PosteriorResult:
    """Posterior weights of the instances (Eq. 2, 16, 17).

    The likelihood is Gaussian in eps_o(theta) - mean (Eq. 17), with
    eps_o = g(theta) - y (Eq. 14) and ``mean`` the combined-uncertainty mean
    (scalar or per sensor). ``covariance`` is a vector of variances (the
    paper's independence assumption) or a full matrix. ``prior`` is one
    non-negative weight per instance; the default is uniform (Eq. 16).
    Normalisation uses log-sum-exp, so very peaked likelihoods do not underflow.

    Parameters
    ----------
    predictions : array_like
        g(theta), one row per instance, one column per sensor.
    measurements : array_like
        y, one per sensor.
    covariance : array_like
        Variances (n_m,) or a covariance matrix (n_m, n_m).
    mean : float or array_like, default 0.0
        Mean of the combined uncertainty, scalar or per sensor.
    prior : array_like, optional
        One non-negative weight per instance; uniform by default.
    mass : float, default 0.95
        Mass of the highest-posterior-density set.

    Returns
    -------
    PosteriorResult

    Raises
    ------
    ValueError
        If the shapes disagree, the prior is negative or all zero, ``mass`` is
        not in (0, 1), or the covariance is invalid.

    Examples
    --------
    >>> from edmf_rs.paper import baselines
    >>> r = baselines.bayesian_posterior([[1.0], [2.0], [3.0]], [2.9], covariance=[0.01], mass=0.95)
    >>> r.map_index, r.hpd_size
    (2, 1)
    """
    y = finite_vector(measurements, "measurements")
    g = _predictions(predictions, y.shape[0])
    mu = _per_sensor(mean, y.shape[0], "mean")
    mass = probability(mass, "mass")
    log_prior = _log_prior(prior, g.shape[0])
    log_like = gaussian_log_likelihood(g - y - mu, covariance)
    log_post = log_like + log_prior
    posterior = np.exp(log_post - special.logsumexp(log_post))
    return PosteriorResult(posterior=posterior, log_likelihood=log_like,
                           hpd_mask=hpd_mask(posterior, mass), mass=mass)
