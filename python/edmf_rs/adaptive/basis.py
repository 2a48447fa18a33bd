"""Emulators on a reduced output basis, for models with many sensors (issue 16, step 2).

With tens of sensors one GP per sensor costs tens of O(n^3) fits, although
a structure's sensors usually follow a few modes (strain gauges along a
girder all follow its bending). Here the outputs are standardised per
sensor, z_i = (g_i - m_i) / s_i, and decomposed by a singular value
decomposition of the runs, Z = U S V^T; the leading k principal components
(the fewest explaining ``variance_kept`` of the variance, 99.9 % by default)
are emulated, one GP each (:class:`~.emulator.SensorEmulators` on the scores
t = Z V_k), and mapped back:

    mu_i(x)      = m_i + s_i sum_j V_ij mu_j(x)
    sigma_i^2(x) = s_i^2 [ sum_j V_ij^2 sigma_j^2(x) + r_i ]

with r_i = mean over runs of (Z - Z V_k V_k^T)_i^2, the variance the
discarded components leave at sensor i (the truncation residual). The
components' GPs are independent, so their variances add with weights
V_ij^2; the residual term keeps the screening conservative where the kept
components do not describe a sensor exactly. The leave-one-out check
(:meth:`PCAEmulators.validate`) is per sensor, like the per-sensor
emulators', on the reconstructed outputs.
"""

from __future__ import annotations

import numpy as np

from .emulator import SensorEmulators, Validation, checked_runs

#: Share of the standardised outputs' variance the kept components explain.
VARIANCE_KEPT = 0.999


class PCAEmulators:
    """GPs on the leading principal components of the standardised outputs.

    Parameters
    ----------
    u : (n, p) array in [0, 1]
    g : (n, n_m) array of finite model outputs
    previous : PCAEmulators, optional
        Its components' kernels start this fit's search (or are kept when
        ``optimize`` is False and the number of components is unchanged).
    optimize : bool
        Search the hyperparameters (else refactorise with the previous ones).
    variance_kept : float
        Least share of the standardised outputs' variance the kept
        components must explain, in (0, 1].

    Attributes
    ----------
    n_components : int
        Components emulated (k).
    basis : numpy.ndarray
        V_k, shape (n_m, k).
    residual_variance : numpy.ndarray
        r_i per sensor (standardised units): the truncation residual.

    Raises
    ------
    EmulatorError
        Non-finite outputs or too few runs.

    Examples
    --------
    >>> import numpy as np
    >>> u = np.random.default_rng(0).random((30, 2))
    >>> latent = np.column_stack([np.sin(3 * u[:, 0]), u[:, 0] * u[:, 1]])
    >>> g = latent @ np.random.default_rng(1).normal(size=(2, 12))
    >>> em = PCAEmulators(u, g)
    >>> em.n_components, em.n_sensors
    (2, 12)
    >>> mu, sd = em.predict(u[:3])
    >>> bool(np.allclose(mu, g[:3], atol=1e-6) and (sd >= 0).all())
    True
    """

    def __init__(self, u: np.ndarray, g: np.ndarray, previous: PCAEmulators | None = None, optimize: bool = True,
                 variance_kept: float = VARIANCE_KEPT):
        u, g, n, p = checked_runs(u, g)
        self.p, self.n_sensors, self.n_runs = p, g.shape[1], n
        self.center = g.mean(axis=0)
        spread = g.std(axis=0)
        self.scale = np.where(spread > 0, spread, 0.0)  # a constant sensor: mean exact, sigma 0
        z = (g - self.center) / np.where(spread > 0, spread, 1.0)
        _, s, vt = np.linalg.svd(z, full_matrices=False)
        var = s**2
        total = var.sum()
        if total > 0:
            k = int(np.searchsorted(np.cumsum(var) / total, variance_kept - 1e-12) + 1)
        else:
            k = 1
        k = min(k, vt.shape[0])
        v = vt[:k].T.copy()
        # Sign convention (the SVD's signs are arbitrary): each component's largest entry is positive.
        flip = np.sign(v[np.abs(v).argmax(axis=0), np.arange(k)])
        v *= np.where(flip == 0, 1.0, flip)
        self.basis = v
        self.n_components = k
        self.scores = z @ v
        self.z = z
        self.residual_variance = ((z - self.scores @ v.T) ** 2).mean(axis=0)
        same = isinstance(previous, PCAEmulators) and previous.n_components == k
        self.latent = SensorEmulators(u, self.scores, previous=previous.latent if same else None,
                                      optimize=optimize or not same)
        self.problems = [text.replace("sensor ", "output component ", 1) for text in self.latent.problems]

    def _to_sensors(self, mu_t: np.ndarray, var_t: np.ndarray | None):
        mu = self.center + self.scale * (mu_t @ self.basis.T)
        if var_t is None:
            return mu, None
        var = var_t @ (self.basis**2).T + self.residual_variance  # sum_j V_ij^2 sigma_j^2 + r_i
        return mu, self.scale * np.sqrt(var)

    def mean(self, u: np.ndarray) -> np.ndarray:
        """Predictive mean of every sensor, shape (N, n_m)."""
        u = np.asarray(u, dtype=np.float64)
        return self._to_sensors(self.latent.mean(u), None)[0]

    def predict(self, u: np.ndarray, chunk: int = 8192) -> tuple[np.ndarray, np.ndarray]:
        """Mean and standard deviation of every sensor, shape (N, n_m) each."""
        mu_t, sd_t = self.latent.predict(u, chunk)
        return self._to_sensors(mu_t, sd_t**2)

    def prior_std(self) -> np.ndarray:
        """Per sensor, an upper bound of the predictive deviation anywhere:
        each component's variance is at most its prior's."""
        return self._to_sensors(np.zeros((1, self.n_components)), self.latent.prior_std()[None] ** 2)[1][0]

    def predict_for_screening(self, u: np.ndarray, measurements: np.ndarray, low: np.ndarray, high: np.ndarray,
                              c: float) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`SensorEmulators.predict_for_screening`: exact deviations
        only where the prior bound would not already reject the point."""
        u = np.asarray(u, dtype=np.float64)
        bound = self.prior_std()
        mu = self.mean(u)
        r = mu - measurements
        alive = ((r >= low - c * bound) & (r <= high + c * bound)).all(axis=1)
        sd = np.broadcast_to(bound, mu.shape).copy()
        if alive.any():
            rows = u[alive]
            var_t = np.column_stack([self.latent._std(j, rows) for j in range(self.n_components)]) ** 2
            sd[alive] = self._to_sensors(np.zeros_like(var_t), var_t)[1]
        return mu, sd

    def validate(self, width: np.ndarray, c: float, coverage: float) -> Validation:
        """Leave-one-out check per sensor on the reconstructed outputs.

        The left-out run's standardised residual at sensor i is its
        truncation residual plus sum_j V_ij e_j (e_j: component j's
        leave-one-out residual, Rasmussen & Williams 2006, Eq. 5.12); its
        variance is sum_j V_ij^2 sigma_{j,-i}^2 + r_i.
        """
        res_t = np.empty((self.n_runs, self.n_components))
        var_t = np.empty_like(res_t)
        for j in range(self.n_components):
            res_t[:, j], sd = self.latent.loo(j)
            var_t[:, j] = sd**2
        residual = (self.z - self.scores @ self.basis.T) + res_t @ self.basis.T
        sd = np.sqrt(var_t @ (self.basis**2).T + self.residual_variance)
        varying = self.scale > 0
        error = np.where(varying, np.sqrt(np.mean((residual * self.scale) ** 2, axis=0)) / width, 0.0)
        cover = np.where(varying, np.mean(np.abs(residual) <= c * sd, axis=0), 1.0)
        return Validation(error, cover, cover >= coverage)


def emulators(u: np.ndarray, g: np.ndarray, basis: str, previous=None, optimize: bool = True,
              variance_kept: float = VARIANCE_KEPT):
    """Per-sensor GPs (``basis = "sensors"``) or GPs on principal components (``"pca"``).

    Examples
    --------
    >>> import numpy as np
    >>> u = np.linspace(0, 1, 10)[:, None]
    >>> type(emulators(u, np.column_stack([u[:, 0], 2 * u[:, 0]]), "pca")).__name__
    'PCAEmulators'
    """
    if basis == "pca":
        return PCAEmulators(u, g, previous if isinstance(previous, PCAEmulators) else None, optimize, variance_kept)
    return SensorEmulators(u, g, previous if isinstance(previous, SensorEmulators) else None, optimize)
