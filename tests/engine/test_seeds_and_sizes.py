"""Seeds and sizes are checked up front: a bad seed names ``seed`` (not
NumPy's SeedSequence), and U_c too large for this machine is refused with the
number instead of swapping for hours."""

import edmf_rs
import numpy as np
import pytest
from edmf_rs.engine import _validate
from edmf_rs.engine.sampling import Parameter, latin_hypercube, sobol
from scipy import stats

UNIFORM = stats.uniform(-0.5, 1.0)  # not normal: U_c is drawn with the seed


@pytest.mark.parametrize("seed, error, match", [
    (-1, ValueError, r"seed: expected an integer >= 0, a numpy.random.Generator or None, got -1"),
    ("a", TypeError, r"seed: expected an integer >= 0, a numpy.random.Generator or None, got str"),
    (True, TypeError, r"seed: expected an integer >= 0, .* got bool"),
    (1.5, TypeError, r"seed: expected an integer >= 0, .* got float"),
])
def test_combine_names_a_bad_seed(seed, error, match):
    with pytest.raises(error, match=match):
        edmf_rs.combine(model=UNIFORM, n_sensors=2, n_samples=1000, seed=seed)
    with pytest.raises(error, match=match):  # unused by normal sources, still checked
        edmf_rs.combine(model=stats.norm(0, 1), n_sensors=2, seed=seed)


def test_other_seeds_are_checked_alike():
    uc = edmf_rs.combine(model=UNIFORM, n_sensors=2, n_samples=1000)
    with pytest.raises(ValueError, match=r"seed: expected an integer >= 0, got -1"):
        edmf_rs.threshold_bounds(uc, method="monte-carlo", seed=-1)
    with pytest.raises(TypeError, match=r"seed: expected an integer >= 0, got str"):
        edmf_rs.threshold_bounds(uc, method="monte-carlo", seed="a")
    for make in (latin_hypercube, sobol):
        with pytest.raises(ValueError, match=r"seed: expected an integer >= 0, a numpy.random.Generator or None"):
            make([Parameter("a", 0.0, 1.0)], 8, seed=-3)
    assert _validate.check_seed(np.int64(7)) == 7 and type(_validate.check_seed(np.int64(7))) is int
    with pytest.raises(TypeError, match=r"base_seed: expected an integer >= 0, got Generator"):
        _validate.check_seed(np.random.default_rng(0), "base_seed")


@pytest.mark.parametrize("model, match", [
    ([stats.uniform(0, 1)], r"n_sensors: 200,000 Monte Carlo samples at 1,000,000,000,000 sensors are drawn as "
                            r"2 x 200,000 x 1,000,000,000,000 values \([\d,.]+ GiB\), more than half this machine's "
                            r"memory .*expected fewer sensors or a smaller n_samples"),
    ([stats.norm(0, 1)], r"n_sensors: U_c at 1,000,000,000,000 sensors takes 8 x 1,000,000,000,000 values"),
])
def test_unallocatable_n_sensors_is_refused_up_front(model, match):
    with pytest.raises(ValueError, match=match):
        edmf_rs.combine(model=model, n_sensors=10**12)


def test_unallocatable_samples_of_vectorised_sources_name_n_samples():
    with pytest.raises(ValueError, match=r"n_samples: 10,000,000,000 Monte Carlo samples at 3 sensors"):
        edmf_rs.combine(model=stats.uniform(0, [1.0, 2.0, 3.0]), n_samples=10**10)
