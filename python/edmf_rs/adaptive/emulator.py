"""Per-sensor Gaussian-process emulators of the model (issue 16, step 2).

One ``sklearn.gaussian_process.GaussianProcessRegressor`` per sensor on the
parameters mapped to the unit cube (standardised inputs), with
``normalize_y=True`` (standardised outputs) and a constant x anisotropic
Matern 5/2 kernel: smooth enough for structural responses, less
overconfident than a squared exponential. A GP gives the predictive standard
deviation the screening needs and a closed-form leave-one-out check; its cost
is O(n^3) in the number of runs n for fitting and O(n^2) per predicted point,
fine for the hundreds of runs adaptive sampling aims at, not for 10^4.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve

#: Nuggets tried in turn (in standardised output units) when a fit's Cholesky fails.
NUGGETS = (1e-10, 1e-8, 1e-6, 1e-4)


def _lbfgs(objective, initial, bounds):
    """L-BFGS-B on the log marginal likelihood, at most 60 iterations: the
    hyperparameters need not be exact, the leave-one-out check judges the fit."""
    from scipy.optimize import minimize

    res = minimize(objective, initial, method="L-BFGS-B", jac=True, bounds=bounds, options={"maxiter": 60})
    return res.x, res.fun


class EmulatorError(ValueError):
    """An emulator that cannot be fitted (NaN outputs, too few runs, a singular kernel).

    A ``ValueError``; its message says which sensor and what to change.

    Attributes
    ----------
    args : tuple of str
        The message.

    Examples
    --------
    >>> issubclass(EmulatorError, ValueError)
    True
    """


def checked_runs(u, g):
    """(u, g, n runs, p parameters) as float64, or an EmulatorError: at least p + 1 runs, finite outputs."""
    u, g = np.asarray(u, dtype=np.float64), np.asarray(g, dtype=np.float64)
    n, p = u.shape
    if n < p + 1:
        raise EmulatorError(f"the emulator needs at least n_params + 1 = {p + 1} runs, got {n}")
    bad = np.flatnonzero(~np.isfinite(g).all(axis=1))
    if bad.size:
        raise EmulatorError(f"run {bad[0]} has a non-finite output; the emulator is fitted on finite outputs only")
    return u, g, n, p


@dataclass(frozen=True, eq=False)
class Validation:
    """Leave-one-out check of every sensor's emulator (Rasmussen & Williams 2006, Eq. 5.12).

    Attributes
    ----------
    error : numpy.ndarray
        Per sensor, the root-mean-square leave-one-out error relative to the
        sensor's threshold width.
    coverage : numpy.ndarray
        Per sensor, the share of runs whose left-out output lies within ``c``
        leave-one-out standard deviations of the prediction (what the
        screening relies on).
    passed : numpy.ndarray of bool
        Per sensor, whether the emulator passed; ``ok``: all of them.

    Examples
    --------
    >>> import numpy as np
    >>> v = Validation(np.array([0.1, 0.3]), np.array([0.97, 0.80]), np.array([True, False]))
    >>> v.ok
    False
    """

    error: np.ndarray
    coverage: np.ndarray
    passed: np.ndarray

    @property
    def ok(self) -> bool:
        return bool(self.passed.all())


class SensorEmulators:
    """A GP per sensor, fitted on runs (unit-cube parameters ``u``, outputs ``g``).

    Parameters
    ----------
    u : (n, p) array in [0, 1]
    g : (n, n_m) array of finite model outputs
    previous : SensorEmulators, optional
        Its fitted kernels start this fit's hyperparameter search (or are
        kept as they are when ``optimize`` is False: the fit is then one
        Cholesky factorisation per sensor instead of a search).

    Examples
    --------
    >>> import numpy as np
    >>> u = np.linspace(0, 1, 12)[:, None]
    >>> em = SensorEmulators(u, np.column_stack([np.sin(3 * u[:, 0]), u[:, 0]]))
    >>> mu, sd = em.predict(np.array([[0.5]]))
    >>> bool(abs(mu[0, 0] - np.sin(1.5)) < 1e-3 and (sd >= 0).all())
    True
    """

    def __init__(self, u: np.ndarray, g: np.ndarray, previous: SensorEmulators | None = None,
                 optimize: bool = True):
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import ConstantKernel, Matern

        u, g, n, p = checked_runs(u, g)
        self.p, self.n_sensors, self.n_runs = p, g.shape[1], n
        self.models: list = []
        self.constant: list[float | None] = []
        self.problems: list[str] = []
        for j in range(g.shape[1]):
            yj = g[:, j]
            if np.ptp(yj) == 0.0:
                self.models.append(None)
                self.constant.append(float(yj[0]))
                self.problems.append(f"sensor {j}: every run gave {yj[0]:g}; emulated as that constant")
                continue
            self.constant.append(None)
            if previous is not None and previous.models[j] is not None:
                kernel = previous.models[j].kernel_
            else:
                kernel = ConstantKernel(1.0, (1e-4, 1e4)) * Matern(np.full(p, 0.3), (1e-3, 1e3), nu=2.5)
            fitted, last = None, None
            for nugget in NUGGETS:
                keep = not optimize and previous is not None and previous.models[j] is not None
                gp = GaussianProcessRegressor(kernel, alpha=nugget, normalize_y=True, n_restarts_optimizer=0,
                                              optimizer=None if keep else _lbfgs)
                try:
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")  # hyperparameters at a bound: validation judges the fit
                        fitted = gp.fit(u, yj)
                    break
                except (np.linalg.LinAlgError, ValueError) as exc:
                    last = exc
            if fitted is None:
                raise EmulatorError(f"sensor {j}: the Gaussian process could not be fitted ({last})")
            self.models.append(fitted)

    def predict(self, u: np.ndarray, chunk: int = 8192) -> tuple[np.ndarray, np.ndarray]:
        """Mean and standard deviation, shape (N, n_m) each, in chunks of rows."""
        u = np.asarray(u, dtype=np.float64)
        mu = np.empty((u.shape[0], self.n_sensors))
        sd = np.empty_like(mu)
        for first in range(0, u.shape[0], chunk):
            part = slice(first, first + chunk)
            for j in range(self.n_sensors):
                mu[part, j] = self._mean(j, u[part])
                sd[part, j] = self._std(j, u[part])
        return mu, sd

    def prior_std(self) -> np.ndarray:
        """Per sensor, an upper bound of the predictive standard deviation
        anywhere: the prior's, sqrt(k(x, x)), since conditioning on runs only
        lowers the variance."""
        out = np.zeros(self.n_sensors)
        for j, gp in enumerate(self.models):
            if gp is not None:
                diag = gp.kernel_.diag(np.zeros((1, self.p)))[0]
                out[j] = np.sqrt(diag) * float(np.atleast_1d(gp._y_train_std)[0])
        return out

    def predict_for_screening(self, u: np.ndarray, measurements: np.ndarray, low: np.ndarray, high: np.ndarray,
                              c: float) -> tuple[np.ndarray, np.ndarray]:
        """Mean and standard deviation where the screening needs them.

        The mean is cheap (O(n) per point), the deviation is not (O(n^2)). A
        point whose mean leaves the thresholds widened by c times the prior
        deviation bound (:meth:`prior_std`) at some sensor is rejected whatever
        its deviation, so it gets that bound instead of its deviation: the
        screening verdict is the same as with the exact deviations.
        """
        u = np.asarray(u, dtype=np.float64)
        bound = self.prior_std()
        mu = np.column_stack([self._mean(j, u) for j in range(self.n_sensors)])
        r = mu - measurements
        alive = ((r >= low - c * bound) & (r <= high + c * bound)).all(axis=1)
        sd = np.broadcast_to(bound, mu.shape).copy()
        if alive.any():
            rows = u[alive]
            sd[alive] = np.column_stack([self._std(j, rows) for j in range(self.n_sensors)])
        return mu, sd

    def _mean(self, j: int, u: np.ndarray) -> np.ndarray:
        gp = self.models[j]
        if gp is None:
            return np.full(u.shape[0], self.constant[j])
        k = gp.kernel_(u, gp.X_train_)
        return k @ gp.alpha_.ravel() * float(np.atleast_1d(gp._y_train_std)[0]) + \
            float(np.atleast_1d(gp._y_train_mean)[0])

    def _std(self, j: int, u: np.ndarray) -> np.ndarray:
        gp = self.models[j]
        if gp is None:
            return np.zeros(u.shape[0])
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*variances smaller than 0.*")
            return gp.predict(u, return_std=True)[1]

    def mean(self, u: np.ndarray) -> np.ndarray:
        """Predictive mean of every sensor, shape (N, n_m) (cheap: no deviation)."""
        u = np.asarray(u, dtype=np.float64)
        return np.column_stack([self._mean(j, u) for j in range(self.n_sensors)])

    def loo(self, j: int) -> tuple[np.ndarray, np.ndarray]:
        """Leave-one-out residuals y_i - mu_{-i} and deviations of sensor ``j``'s GP, in output units.

        With K the fitted covariance (nugget included) and alpha = K^-1 y:
        y_i - mu_{-i} = alpha_i / [K^-1]_ii and var_{-i} = 1 / [K^-1]_ii
        (Rasmussen & Williams 2006, Eq. 5.12), scaled back to output units.
        A constant sensor has zeros.
        """
        gp = self.models[j]
        if gp is None:
            return np.zeros(self.n_runs), np.zeros(self.n_runs)
        k_inv = cho_solve((gp.L_, True), np.eye(gp.L_.shape[0]))
        d = np.diag(k_inv)
        scale = float(np.atleast_1d(gp._y_train_std)[0])
        return gp.alpha_.ravel() / d * scale, np.sqrt(1.0 / d) * scale

    def validate(self, width: np.ndarray, c: float, coverage: float) -> Validation:
        """Closed-form leave-one-out residuals and deviations of every sensor's GP (:meth:`loo`)."""
        error = np.zeros(self.n_sensors)
        cover = np.ones(self.n_sensors)
        for j, gp in enumerate(self.models):
            if gp is None:
                continue
            residual, sd = self.loo(j)
            error[j] = np.sqrt(np.mean(residual**2)) / width[j]
            cover[j] = np.mean(np.abs(residual) <= c * sd)
        return Validation(error, cover, cover >= coverage)
