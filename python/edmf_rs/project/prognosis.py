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


@dataclass(frozen=True, eq=False)
class Prognosis:
    """A quantity of interest over the candidate model set.

    ``values`` holds q(theta) of every candidate; ``model_low``/``model_high``
    their range; ``low``/``high`` the range once the QoI's own model
    uncertainty is included (equal to the former without one).
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
        own model uncertainty, the range the true value is in."""
        unit = f" {self.unit}" if self.unit else ""
        span = f"{self.model_low:.4g} .. {self.model_high:.4g}{unit}"
        if self.uncertainty is None:
            return f"{self.name}: the candidate models predict {span} (no model uncertainty given for it)"
        a, b = self.uncertainty_interval
        return (f"{self.name}: the candidate models predict {span}; with its model uncertainty "
                f"({self.probability:.0%} interval of prediction - true value: {a:.4g} .. {b:.4g}{unit}), "
                f"the true value is in {self.low:.4g} .. {self.high:.4g}{unit}")

    def as_dict(self) -> dict:
        return {"name": self.name, "unit": self.unit, "candidates": self.n_candidates,
                "model_range": [self.model_low, self.model_high], "range": [self.low, self.high],
                "probability": self.probability if self.uncertainty is not None else None,
                "uncertainty_interval": list(self.uncertainty_interval) if self.uncertainty is not None else None}


def predict(qoi_model: Callable, candidate_parameters, *, uncertainty=None, probability: float = 0.95,
            name: str = "quantity of interest", unit: str = "") -> Prognosis:
    """Evaluates ``qoi_model`` on the candidates' parameters (n_c, p) and gives its range.

    ``qoi_model`` is vectorised: (n_c, p) -> (n_c,) (or (n_c, 1)).
    ``uncertainty`` is a scalar frozen ``scipy.stats`` distribution of the QoI
    model's error eps_q (Eq. 4 sign: prediction minus true value), or None.
    """
    theta = np.asarray(candidate_parameters, dtype=np.float64)
    if theta.ndim != 2:
        raise ValueError(f"candidate_parameters: expected an (n_c, p) array, got shape {theta.shape}")
    if theta.shape[0] == 0:
        raise ValueError(f"{name}: no candidate models (the model class is falsified), so no prognosis")
    if not callable(qoi_model):
        raise TypeError(f"qoi_model: expected a callable, got {type(qoi_model).__name__}")
    q = np.asarray(qoi_model(theta), dtype=np.float64)
    if q.ndim == 2 and q.shape[1] == 1:
        q = q[:, 0]
    if q.shape != (theta.shape[0],):
        raise ValueError(f"{name}: the QoI model returned shape {q.shape} for {theta.shape[0]} candidates, "
                         f"expected ({theta.shape[0]},): one value per candidate")
    if not np.all(np.isfinite(q)):
        i = int(np.flatnonzero(~np.isfinite(q))[0])
        raise ValueError(f"{name}: the QoI model returned {q[i]} for candidate {i} ({theta[i].tolist()})")
    probability = check_probability(probability, "probability")
    a = b = 0.0
    if uncertainty is not None:
        if not intervals.is_frozen(uncertainty) or intervals.batch_shape(uncertainty) != ():
            raise TypeError("uncertainty: expected a scalar frozen scipy.stats distribution (e.g. norm(0, 0.5))")
        tail = 0.5 * (1.0 - probability)
        a, b = float(uncertainty.ppf(tail)), float(uncertainty.ppf(1.0 - tail))
    q.flags.writeable = False
    lo, hi = float(q.min()), float(q.max())
    return Prognosis(name, unit, q, probability, uncertainty, (a, b), lo, hi, lo - b, hi - a)
