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

    Attributes
    ----------
    number : int
        1, 2 or 3.
    K : float
        The true rotational stiffness of the support, N mm/rad (``math.inf``:
        rigid, no model error).
    model_uncertainty_recognised : bool
        Whether the combined uncertainty includes the model simplification
        uncertainty (``MODEL_FRACTION`` of the measured value) or only the
        sensor noise.
    name : str
        The paper's name of the scenario.
    has_model_error : bool
        True when the support is not rigid.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> [(s.number, s.has_model_error, s.model_uncertainty_recognised) for s in cl.SCENARIOS]
    [(1, False, False), (2, True, True), (3, True, False)]
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
    """Scenario 1, 2 or 3 of Sec. 4.1.

    Parameters
    ----------
    number : int
        1, 2 or 3.

    Returns
    -------
    Scenario

    Raises
    ------
    ValueError
        For any other number.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> cl.scenario(2).name
    'Recognised systematic errors'
    """
    for s in SCENARIOS:
        if s.number == number:
            return s
    raise ValueError(f"number: expected 1, 2 or 3, got {number!r}")


def sensor_positions(n_m: int) -> np.ndarray:
    """Sensor positions x_i = x_start + i (l - x_start) / n_m for i = 1..n_m (Sec. 4.1), in mm.

    Parameters
    ----------
    n_m : int
        Number of sensors, at least 1.

    Returns
    -------
    numpy.ndarray
        (n_m,) positions; the last one at the free end.

    Raises
    ------
    ValueError
        If ``n_m`` is not a positive integer.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> cl.sensor_positions(2).tolist()
    [1750.0, 3000.0]
    """
    n_m = positive_int(n_m, "n_m")
    return X_START + np.arange(1, n_m + 1) * (LENGTH - X_START) / n_m


def deflection(x, E) -> np.ndarray:
    """Idealised cantilever v(x) = F x^2 (3l - x) / (6 E I) (Eq. 12), in mm.

    Parameters
    ----------
    x : array_like
        Sensor positions (n_m,), mm.
    E : float or array_like
        Young's moduli (N,), MPa.

    Returns
    -------
    numpy.ndarray
        Predictions of shape (N, n_m), one row per model instance; (n_m,)
        for a scalar ``E``.

    Raises
    ------
    ValueError
        If ``x`` is not finite or ``E`` is not finite and positive.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> round(float(cl.deflection([3000.0], 70e3)[0]), 4)
    0.9524
    """
    x = finite_vector(x, "x")
    E = np.asarray(E, dtype=np.float64)
    if not np.all(np.isfinite(E)) or np.any(E <= 0):
        raise ValueError("E: expected finite positive Young's moduli")
    shape = FORCE * x**2 * (3.0 * LENGTH - x) / (6.0 * INERTIA)
    return shape / E[..., None] if E.ndim else shape / float(E)


def predictions(x, E=E_GRID) -> np.ndarray:
    """g(theta) for every model instance of the grid (Eq. 12).

    Parameters
    ----------
    x : array_like
        Sensor positions (n_m,), mm.
    E : array_like, default E_GRID
        Young's moduli of the instances, MPa: the paper's 101-point grid.

    Returns
    -------
    numpy.ndarray
        Shape (len(E), n_m).

    Raises
    ------
    ValueError
        As `deflection`.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> cl.predictions(cl.sensor_positions(10)).shape
    (101, 10)
    """
    return deflection(x, np.atleast_1d(np.asarray(E, dtype=np.float64)))


def model_error(x, K: float) -> np.ndarray:
    """eps(x) = -F l x / K, the error of the idealised model (zero when K is infinite).

    Parameters
    ----------
    x : array_like
        Sensor positions (n_m,), mm.
    K : float
        Rotational stiffness of the support, N mm/rad, or ``math.inf``.

    Returns
    -------
    numpy.ndarray
        (n_m,) errors (prediction minus true value), mm: negative, the model
        under-predicts.

    Raises
    ------
    ValueError
        If ``K`` is not positive.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> cl.model_error([3000.0], 12e10).round(4).tolist()
    [-0.375]
    """
    x = finite_vector(x, "x")
    if not K > 0:
        raise ValueError(f"K: expected a positive stiffness (or math.inf), got {K}")
    return -FORCE * LENGTH * x / K


def true_displacement(x, K: float, E: float = E_TRUE) -> np.ndarray:
    """Displacement of the true beam, v*(x) - eps(x) (Eq. 13 without noise).

    Parameters
    ----------
    x : array_like
        Sensor positions (n_m,), mm.
    K : float
        Rotational stiffness of the support, N mm/rad, or ``math.inf``.
    E : float, default E_TRUE
        Young's modulus, MPa.

    Returns
    -------
    numpy.ndarray
        (n_m,) displacements, mm.

    Raises
    ------
    ValueError
        As `deflection` and `model_error`.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> cl.true_displacement([3000.0], 12e10).round(4).tolist()
    [1.3274]
    """
    return deflection(x, E) - model_error(x, K)


def simulate_measurements(x, K: float, rng=None, *, size: int | None = None,
                          E: float = E_TRUE, sensor_sd: float = SENSOR_SD) -> np.ndarray:
    """Simulated measurements y = v*(x) - eps(x) + u_meas (Eq. 13).

    Parameters
    ----------
    x : array_like
        Sensor positions (n_m,), mm.
    K : float
        Rotational stiffness of the support, N mm/rad, or ``math.inf``.
    rng : numpy.random.Generator, int or None
        Source of the sensor noise, N(0, sensor_sd), independent between sensors.
    size : int, optional
        Number of independent draws (row k does not depend on ``size``).
    E : float, default E_TRUE
        Young's modulus of the true beam, MPa.
    sensor_sd : float, default SENSOR_SD
        Standard deviation of the sensor noise, mm.

    Returns
    -------
    numpy.ndarray
        Shape (n_m,), or (size, n_m).

    Raises
    ------
    ValueError
        If ``size`` is not a positive integer, or as `true_displacement`.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> cl.simulate_measurements(cl.sensor_positions(10), K=12e10, rng=1, size=5).shape
    (5, 10)
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
    `combined_uncertainty`, without building scipy objects per draw.

    Parameters
    ----------
    scn : Scenario
        Whether the model uncertainty is recognised.
    measured : array_like
        (n_m,) or (draws, n_m) measured values.

    Returns
    -------
    tuple of numpy.ndarray
        Mean and standard deviation of U_c, each of the shape of ``measured``.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> mean, sd = cl.combined_moments(cl.scenario(2), [1.0])
    >>> mean.round(3).tolist(), sd.round(4).tolist()
    ([-0.1], [0.1513])
    """
    y = np.asarray(measured, dtype=np.float64)
    if scn.model_uncertainty_recognised:
        frac_mean, frac_sd = float(MODEL_FRACTION.mean()), float(MODEL_FRACTION.std())
        return frac_mean * y, np.sqrt((frac_sd * y) ** 2 + SENSOR_SD**2)
    return np.zeros_like(y), np.full_like(y, SENSOR_SD)


def combined_uncertainty(scn: Scenario, measured) -> CombinedUncertainty:
    """U_c of one set of measurements through `edmf_rs.combine` (exact normal).

    Parameters
    ----------
    scn : Scenario
        Whether the model uncertainty is recognised.
    measured : array_like
        (n_m,) measured values.

    Returns
    -------
    CombinedUncertainty

    Raises
    ------
    ValueError
        If ``measured`` is not a finite vector.

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> uc = cl.combined_uncertainty(cl.scenario(2), [1.0])
    >>> uc.exact, uc.std.round(4).tolist()
    (True, [0.1513])
    """
    y = finite_vector(measured, "measured")
    model = [relative_to_measured(MODEL_FRACTION, y)] if scn.model_uncertainty_recognised else []
    return combine(model=model, measurement=[stats.norm(0.0, SENSOR_SD)], n_sensors=y.shape[0])
