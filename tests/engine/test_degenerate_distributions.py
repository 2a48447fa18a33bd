"""A distribution whose parameters scipy turns into NaN quantiles (a zero or
negative scale, a NaN location, a shape outside its domain) is refused naming
the argument the user passed and the sensor, not the ``low`` bound computed
from it."""

import edmf_rs
import numpy as np
import pytest
from scipy import stats

UNIT = stats.uniform(0, 1)


@pytest.mark.parametrize("combined, match", [
    ([stats.norm(0, 0)], r"combined: expected a finite scale > 0, got scale=0.0 at sensor 0 \(norm\)"),
    ([stats.norm(np.nan, 1)], r"combined: expected a finite location, got loc=nan at sensor 0 \(norm\)"),
    ([stats.norm(0, -1)], r"combined: expected a finite scale > 0, got scale=-1.0 at sensor 0"),
    ([stats.norm(0, 1), stats.norm(0, np.inf)], r"combined: expected a finite scale > 0, got scale=inf at sensor 1"),
    ([stats.norm(0, 1), stats.uniform(3, 0)], r"combined: expected a finite scale > 0, got scale=0.0 at sensor 1 "
                                              r"\(uniform\)"),
    ([stats.lognorm(-1.0)], r"combined: expected shape parameters valid for scipy.stats.lognorm, got shape "
                            r"parameters -1.0 at sensor 0"),
    ([stats.norm(0, 1), stats.lognorm(0.5, scale=0)], r"combined: expected a finite scale > 0, got scale=0.0 "
                                                      r"at sensor 1 \(lognorm\)"),
    # One distribution vectorised over the sensors: the symmetric route (ppf) and the others.
    (stats.norm(0, [1.0, 0.0]), r"combined: expected a finite scale > 0, got scale=0.0 at sensor 1 \(norm\)"),
    (stats.uniform([0.0, np.nan], 1.0), r"combined: expected a finite location, got loc=nan at sensor 1"),
    (stats.gamma([2.0, 2.0, -1.0]), r"combined: expected shape parameters valid for scipy.stats.gamma, got shape "
                                    r"parameters -1.0 at sensor 2"),
])
def test_threshold_bounds_names_the_bad_distribution(combined, match):
    with pytest.raises(ValueError, match=match):
        edmf_rs.threshold_bounds(combined)


def test_combine_names_the_source_and_sensor():
    with pytest.raises(ValueError, match=r"model\[0\]: expected shape parameters valid for scipy.stats.lognorm"):
        edmf_rs.combine(model=stats.lognorm(-1.0), n_sensors=2, n_samples=1000)
    with pytest.raises(ValueError, match=r"measurement\[1\]: expected a finite scale >= 0, got scale=-1.0 at sensor 1 "
                                         r"\(uniform\)"):
        edmf_rs.combine(model=stats.norm(0, 1), measurement=[stats.norm(0, 1), [UNIT, stats.uniform(0, -1)]],
                        n_samples=1000)


@pytest.mark.parametrize("model, measurement, sensor", [
    (stats.uniform(0, 0), (), 0),  # a single source of zero width
    ([stats.uniform(0, [1.0, 0.0])], stats.laplace(5, [1.0, 0.0]), 1),  # every source of sensor 1 a fixed offset
])
def test_combine_refuses_a_sensor_without_spread(model, measurement, sensor):
    """As for normal sources: U_c constant at a sensor gives zero-width thresholds."""
    with pytest.raises(ValueError, match=rf"model, measurement: the combined standard deviation is zero at sensor "
                                         rf"{sensor}$"):
        edmf_rs.combine(model=model, measurement=measurement, n_sensors=2, n_samples=1000)
