"""Arguments of edmf_rs.design refused alike by every function, each message
naming the argument and saying what it is (a count is not an index, a single
number is not an array of shape (1,), integer sensor types are types)."""

import edmf_rs
import numpy as np
import pytest
import scipy.stats as st
from edmf_rs import design

G = np.random.default_rng(0).normal(size=(300, 4))
W = [0.5] * 4
COMBINED = edmf_rs.combine(measurement=[st.norm(0, 0.3)], n_sensors=4)


def _with(value):
    g = G.copy()
    g[19, 3] = value
    return g


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("call", [
    lambda g: design.expected_identifiability(g, COMBINED, [0, 3], n_simulations=50),
    lambda g: design.identifiability_curve(g, COMBINED, [3, 0], n_simulations=50),
], ids=["expected_identifiability", "identifiability_curve"])
def test_identifiability_refuses_non_finite_predictions_as_placement_does(call, value):
    with pytest.raises(ValueError, match=rf"^predictions: expected finite values, got {value} at instance 19, "
                                         r"location 3; leave out the instances"):
        call(_with(value))


def test_placement_and_entropy_refuse_nan_too():
    for call in (lambda: design.place_sensors(_with(np.nan), W, 2), lambda: design.joint_entropy(_with(np.nan), W)):
        with pytest.raises(ValueError, match=r"^predictions: .*instance 19, location 3"):
            call()


@pytest.mark.parametrize("k", [2.0, "2", True])
def test_k_is_a_number_of_sensors(k):
    with pytest.raises(TypeError, match=rf"^k: expected a number of sensors \(an integer\), got {k!r}$"):
        design.place_sensors(G, W, k)


def test_fixed_are_location_indices():
    with pytest.raises(TypeError, match=r"^fixed: expected location indices \(integers\), got 1.0$"):
        design.place_sensors(G, W, 2, fixed=[1.0])


@pytest.mark.parametrize("name", ["widths", "costs"])
def test_a_single_number_is_named_as_one(name):
    kwargs = {"widths": W, "k": 2, "costs": None}
    kwargs[name] = 0.5
    with pytest.raises(ValueError, match=rf"^{name}: expected one value per location \(4\), got the single "
                                         r"number 0.5 \(for the same value everywhere: \[0.5\] \* 4\)$"):
        design.place_sensors(G, **kwargs)
    with pytest.raises(ValueError, match=rf"^{name}: expected one value per location \(4\), got shape \(1,\)$"):
        kwargs[name] = [0.5]
        design.place_sensors(G, **kwargs)


def test_integer_sensor_types_match_integer_quota_keys():
    types = [1, 2, 2, 1]
    d = design.place_sensors(G, W, 3, types=types, max_per_type={2: 1})
    assert sum(types[i] == 2 for i in d.order) <= 1 and len(d) == 3
    assert d.types == tuple(str(types[i]) for i in d.order)
    # The same design as with the types and keys written as strings.
    same = design.place_sensors(G, W, 3, types=["1", "2", "2", "1"], max_per_type={"2": 1})
    assert d.order.tolist() == same.order.tolist()
    with pytest.raises(ValueError, match=r"^max_per_type: expected sensor types of the locations \(1, 2\), got 3$"):
        design.place_sensors(G, W, 3, types=types, max_per_type={3: 1})
    with pytest.raises(ValueError, match=r"^max_per_type: expected each sensor type once, got 2 and '2'$"):
        design.place_sensors(G, W, 3, types=types, max_per_type={2: 1, "2": 1})
