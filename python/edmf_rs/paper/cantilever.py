"""The cantilever beam of Goulet & Smith (2013), Sec. 4.

The "true" beam has a rotational spring of stiffness K at its support; the
model class is the idealised, fully fixed cantilever (Eq. 12) whose only
parameter is Young's modulus E. Dropping the spring makes the model
under-predict every displacement by ``F l x / K`` (a rigid rotation F l / K of
the whole beam), an error that is perfectly correlated between sensors: the
systematic error the paper studies.

Units: N, mm, MPa. Displacements are positive downwards (in the direction of F).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..engine._validate import finite_vector, positive_int
from ..engine.uncertainty import CombinedUncertainty, combine, relative_to_measured

E_TRUE = 70e3            # E*, MPa
FORCE = 5e3              # F, N (vertical, at the free end)
LENGTH = 3000.0          # l, mm
INERTIA = 6.75e8         # I, mm^4 (300 mm x 300 mm square section)
X_START = 500.0          # x_start, mm: no sensor closer to the support
SENSOR_SD = 0.02         # sd of U_meas, mm (sensor resolution, independent)
K_SEMI_RIGID = 12e10     # K of scenarios 2 and 3, N mm/rad
N_SENSORS = (1, 2, 10, 50)
#: Model simplification error as a fraction of the measured value (Sec. 4.1.2).
MODEL_FRACTION = stats.norm(-0.10, 0.15)
#: The parameter domain [20, 100] x 10^3 MPa "subdivided in 100": 101 model instances.
E_GRID = np.linspace(20e3, 100e3, 101)
E_GRID.flags.writeable = False
GRID_STEP = float(E_GRID[1] - E_GRID[0])


@dataclass(frozen=True)
class Scenario:
    """One of the three cases of Sec. 4.1.

    ``K`` is the true rotational stiffness of the support (``math.inf``: rigid,
    no model error); ``model_uncertainty_recognised`` says whether the
    combined uncertainty includes the model simplification uncertainty
    (``MODEL_FRACTION`` of the measured value) or only the sensor noise.
    """

    number: int
    K: float
    model_uncertainty_recognised: bool
    name: str

    @property
    def has_model_error(self) -> bool:
        return math.isfinite(self.K)


SCENARIOS = (
    Scenario(1, math.inf, False, "No systematic errors"),
    Scenario(2, K_SEMI_RIGID, True, "Recognised systematic errors"),
    Scenario(3, K_SEMI_RIGID, False, "Unrecognised errors"),
)


def scenario(number: int) -> Scenario:
    """Scenario 1, 2 or 3."""
    for s in SCENARIOS:
        if s.number == number:
            return s
    raise ValueError(f"number: expected 1, 2 or 3, got {number!r}")


def sensor_positions(n_m: int) -> np.ndarray:
    """x_i = x_start + i (l - x_start) / n_m for i = 1..n_m (Sec. 4.1), in mm."""
    n_m = positive_int(n_m, "n_m")
    return X_START + np.arange(1, n_m + 1) * (LENGTH - X_START) / n_m


def deflection(x, E) -> np.ndarray:
    """Idealised cantilever v(x) = F x^2 (3l - x) / (6 E I) (Eq. 12).

    ``x`` (n_m,) and ``E`` (N,) give predictions of shape (N, n_m): one row
    per model instance. A scalar ``E`` gives shape (n_m,).
    """
    x = finite_vector(x, "x")
    E = np.asarray(E, dtype=np.float64)
    if not np.all(np.isfinite(E)) or np.any(E <= 0):
        raise ValueError("E: expected finite positive Young's moduli")
    shape = FORCE * x**2 * (3.0 * LENGTH - x) / (6.0 * INERTIA)
    return shape / E[..., None] if E.ndim else shape / float(E)


def predictions(x, E=E_GRID) -> np.ndarray:
    """g(theta) for every model instance of the grid: shape (len(E), n_m)."""
    return deflection(x, np.atleast_1d(np.asarray(E, dtype=np.float64)))


def model_error(x, K: float) -> np.ndarray:
    """eps(x) = -F l x / K, the error of the idealised model (zero when K is infinite)."""
    x = finite_vector(x, "x")
    if not K > 0:
        raise ValueError(f"K: expected a positive stiffness (or math.inf), got {K}")
    return -FORCE * LENGTH * x / K


def true_displacement(x, K: float, E: float = E_TRUE) -> np.ndarray:
    """Displacement of the true beam, v*(x) - eps(x) (Eq. 13 without noise)."""
    return deflection(x, E) - model_error(x, K)


def simulate_measurements(x, K: float, rng=None, *, size: int | None = None,
                          E: float = E_TRUE, sensor_sd: float = SENSOR_SD) -> np.ndarray:
    """Simulated measurements y = v*(x) - eps(x) + u_meas (Eq. 13).

    ``rng`` is a ``numpy.random.Generator`` or a seed. The sensor noise is
    N(0, sensor_sd), independent between sensors. Shape (n_m,), or
    (size, n_m) for ``size`` independent draws (row k does not depend on size).
    """
    rng = np.random.default_rng(rng)
    exact = true_displacement(x, K, E)
    shape = exact.shape if size is None else (positive_int(size, "size"), exact.shape[0])
    return exact + rng.normal(0.0, sensor_sd, size=shape)


def combined_moments(scn: Scenario, measured) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation of U_c = U_model - U_meas per sensor.

    Model uncertainty (when recognised) is N(-10 %, 15 %) of the measured
    value; sensor noise is N(0, 0.02 mm); they add in variance,
    sigma_c^2 = sigma_model^2 + sigma_meas^2 (Sec. 4). Vectorised:
    ``measured`` may be (n_m,) or (draws, n_m). Gives the same numbers as
    :func:`combined_uncertainty`, without building scipy objects per draw.
    """
    y = np.asarray(measured, dtype=np.float64)
    if scn.model_uncertainty_recognised:
        frac_mean, frac_sd = float(MODEL_FRACTION.mean()), float(MODEL_FRACTION.std())
        return frac_mean * y, np.sqrt((frac_sd * y) ** 2 + SENSOR_SD**2)
    return np.zeros_like(y), np.full_like(y, SENSOR_SD)


def combined_uncertainty(scn: Scenario, measured) -> CombinedUncertainty:
    """U_c of one set of measurements through :func:`edmf_rs.combine` (exact normal)."""
    y = finite_vector(measured, "measured")
    model = [relative_to_measured(MODEL_FRACTION, y)] if scn.model_uncertainty_recognised else []
    return combine(model=model, measurement=[stats.norm(0.0, SENSOR_SD)], n_sensors=y.shape[0])
