"""Prognosis: a quantity of interest predicted with the candidate model set.

Every candidate model is an equally possible explanation of the measurements
(Sec. 3.1), so a quantity of interest q (a deflection under a load not
measured, a reserve capacity, ...) is predicted by evaluating it on every
candidate's parameters: its range over the candidates. The QoI model has its
own model uncertainty U_q, with the sign convention of Eq. 4: the true value is
``Q = q(theta) - eps_q``. With ``[a, b]`` the central interval of U_q holding
``probability``, the prognosis range is ``[min q - b, max q - a]``. For a
zero-centred symmetric U_q this is ``[min q - b, max q + b]``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..engine import intervals
from ..engine._validate import probability as check_probability
from ..engine._validate import real_array


@dataclass(frozen=True, eq=False)
class Prognosis:
    """A quantity of interest over the candidate model set, as made by `predict`.

    Attributes
    ----------
    name, unit : str
        What the quantity is, for reports.
    values : numpy.ndarray
        q(theta) of every candidate (read-only).
    n_candidates : int
        Number of candidates.
    probability : float
        Probability of the central interval of the QoI's model uncertainty.
    uncertainty : scipy.stats frozen distribution or None
        The QoI model's error (prediction minus true value, Eq. 4).
    uncertainty_interval : tuple of float
        Its central interval ``(a, b)``; ``(0, 0)`` without one.
    model_low, model_high : float
        The range of ``values``.
    low, high : float
        The range once the QoI's own model uncertainty is included:
        ``[model_low - b, model_high - a]`` (equal to the former without one).

    Examples
    --------
    >>> import numpy as np
    >>> import edmf_rs
    >>> p = edmf_rs.predict(lambda t: 2 * t[:, 0], np.array([[1.0], [3.0]]), name="q", unit="mm")
    >>> p.model_low, p.model_high, p.n_candidates
    (2.0, 6.0, 2)
    >>> print(p.summary())
    q: the candidate models predict 2 .. 6 mm (no model uncertainty given for it)
    """

    name: str
    unit: str
    values: np.ndarray
    probability: float
    uncertainty: object | None
    uncertainty_interval: tuple[float, float]
    model_low: float
    model_high: float
    low: float
    high: float

    @property
    def n_candidates(self) -> int:
        return int(self.values.shape[0])

    def summary(self) -> str:
        """One plain line: what the candidates predict and, with the quantity's
        own model uncertainty, the range the true value is in.

        Returns
        -------
        str
            The line.

        Examples
        --------
        >>> import numpy as np
        >>> from scipy import stats
        >>> import edmf_rs
        >>> p = edmf_rs.predict(lambda t: t[:, 0], np.array([[1.0], [2.0]]),
        ...                     uncertainty=stats.uniform(-0.5, 1.0), name="q")
        >>> "q" in p.summary()
        True
        """
        unit = f" {self.unit}" if self.unit else ""
        span = f"{self.model_low:.4g} .. {self.model_high:.4g}{unit}"
        if self.uncertainty is None:
            return f"{self.name}: the candidate models predict {span} (no model uncertainty given for it)"
        a, b = self.uncertainty_interval
        return (f"{self.name}: the candidate models predict {span}; with its model uncertainty "
                f"({self.probability:.0%} interval of prediction - true value: {a:.4g} .. {b:.4g}{unit}), "
                f"the true value is in {self.low:.4g} .. {self.high:.4g}{unit}")

    def as_dict(self) -> dict:
        """The prognosis for ``summary.json``.

        Returns
        -------
        dict
            ``name``, ``unit``, ``candidates``, ``model_range``, ``range``,
            ``probability`` and ``uncertainty_interval`` (None without an
            uncertainty).

        Examples
        --------
        >>> import numpy as np
        >>> import edmf_rs
        >>> edmf_rs.predict(lambda t: t[:, 0], np.array([[1.0], [2.0]]), name="q").as_dict()["range"]
        [1.0, 2.0]
        """
        return {"name": self.name, "unit": self.unit, "candidates": self.n_candidates,
                "model_range": [self.model_low, self.model_high], "range": [self.low, self.high],
                "probability": self.probability if self.uncertainty is not None else None,
                "uncertainty_interval": list(self.uncertainty_interval) if self.uncertainty is not None else None}


def predict(qoi_model: Callable, candidate_parameters, *, uncertainty=None, probability: float = 0.95,
            name: str = "quantity of interest", unit: str = "") -> Prognosis:
    """Predicts a quantity of interest with the candidate model set: its range over the candidates.

    Every candidate model is an equally possible explanation of the
    measurements (Sec. 3.1), so the prognosis is the range of q(theta) over
    the candidates, widened by the QoI model's own uncertainty: with
    ``[a, b]`` the central interval of its error holding ``probability``, the
    range is ``[min q - b, max q - a]``.

    Parameters
    ----------
    qoi_model : callable
        Vectorised: (n_c, p) parameters -> (n_c,) (or (n_c, 1)) values.
    candidate_parameters : array_like
        The candidates' parameters (n_c, p), e.g.
        ``result.candidate_parameters`` of `falsify_model`.
    uncertainty : scipy.stats frozen distribution, optional
        Scalar distribution of the QoI model's error eps_q (Eq. 4 sign:
        prediction minus true value).
    probability : float, default 0.95
        Probability of the central interval of ``uncertainty``.
    name, unit : str
        For reports and error messages.

    Returns
    -------
    Prognosis
        The values and their ranges.

    Raises
    ------
    ValueError
        If ``candidate_parameters`` is not 2-D or empty (the model class is
        falsified), or the QoI model returns the wrong shape or non-finite
        values.
    TypeError
        If ``qoi_model`` is not callable or ``uncertainty`` is not a scalar
        frozen distribution.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import stats
    >>> import edmf_rs
    >>> theta = np.array([[1.0], [2.0], [4.0]])
    >>> p = edmf_rs.predict(lambda t: 10 * t[:, 0], theta, uncertainty=stats.norm(0, 1))
    >>> round(p.low, 2), round(p.high, 2)
    (8.04, 41.96)
    """
    theta = np.asarray(candidate_parameters, dtype=np.float64)
    if theta.ndim != 2:
        raise ValueError(f"candidate_parameters: expected an (n_c, p) array, got shape {theta.shape}")
    if theta.shape[0] == 0:
        raise ValueError(f"{name}: no candidate models (the model class is falsified), so no prognosis")
    if not callable(qoi_model):
        raise TypeError(f"qoi_model: expected a callable, got {type(qoi_model).__name__}")
    q = real_array(qoi_model(theta), f"{name}: the QoI model's values", copy=False)  # complex: refused
    if q.ndim == 2 and q.shape[1] == 1:
        q = q[:, 0]
    if q.shape != (theta.shape[0],):
        raise ValueError(f"{name}: the QoI model returned shape {q.shape} for {theta.shape[0]} candidates, "
                         f"expected ({theta.shape[0]},): one value per candidate")
    if not np.all(np.isfinite(q)):
        i = int(np.flatnonzero(~np.isfinite(q))[0])
        raise ValueError(f"{name}: the QoI model returned {q[i]} for candidate {i} ({theta[i].tolist()})")
    q.flags.writeable = False
    return over_range(q, float(q.min()), float(q.max()), uncertainty=uncertainty, probability=probability,
                      name=name, unit=unit)


def over_range(values: np.ndarray, low: float, high: float, *, uncertainty=None, probability: float = 0.95,
               name: str = "quantity of interest", unit: str = "") -> Prognosis:
    """The Prognosis of candidates whose q(theta) are ``values``, with their range ``[low, high]``
    already known (computed batch by batch when the candidates stream to a file)."""
    probability = check_probability(probability, "probability")
    a = b = 0.0
    if uncertainty is not None:
        if not intervals.is_frozen(uncertainty) or intervals.batch_shape(uncertainty) != ():
            raise TypeError("uncertainty: expected a scalar frozen scipy.stats distribution (e.g. norm(0, 0.5))")
        tail = 0.5 * (1.0 - probability)
        a, b = float(uncertainty.ppf(tail)), float(uncertainty.ppf(1.0 - tail))
    return Prognosis(name, unit, values, probability, uncertainty, (a, b), low, high, low - b, high - a)
