"""The Rust emulator screening against its NumPy oracle (issue 16, step 3)."""

import edmf_rs
import numpy as np
import pytest
from edmf_rs import reference
from edmf_rs.adaptive.screen import required_margin, screen, screen_reference
from hypothesis import given
from hypothesis import strategies as st


@st.composite
def screening_inputs(draw):
    n = draw(st.integers(0, 3000))
    n_m = draw(st.integers(1, 12))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    mu = rng.normal(0.0, draw(st.sampled_from([0.5, 1.0, 3.0])), (n, n_m))
    sigma = np.abs(rng.normal(0.0, draw(st.sampled_from([0.0, 0.05, 0.5])), (n, n_m)))
    if draw(st.booleans()) and n:  # exact zeros, NaN means and values on the bounds
        sigma[rng.random((n, n_m)) < 0.3] = 0.0
        mu[rng.random((n, n_m)) < 0.01] = np.nan
    y = rng.normal(0.0, 0.3, n_m)
    low = -rng.uniform(0.1, 1.5, n_m)
    high = rng.uniform(0.1, 1.5, n_m)
    if n:
        mu[0] = y + low  # exactly on the lower bound with sigma 0: kept by Eq. 8
        sigma[0] = 0.0
    layout = draw(st.sampled_from(["C", "F", "strided"]))
    if layout == "F":
        mu, sigma = np.asfortranarray(mu), np.asfortranarray(sigma)
    elif layout == "strided":
        mu, sigma = np.repeat(mu, 2, axis=1)[:, ::2], np.repeat(sigma, 2, axis=1)[:, ::2]
    c = draw(st.sampled_from([0.0, 1.0, 3.0, 10.0]))
    return mu, sigma, y, edmf_rs.Thresholds(low, high), c


@given(screening_inputs())
def test_rust_screening_matches_numpy(args):
    mu, sigma, y, t, c = args
    kept, order = screen(mu, sigma, y, t, c)
    np.testing.assert_array_equal(kept, screen_reference(mu, sigma, y, t, c))
    assert sorted(order) == list(range(t.n_sensors))


@given(screening_inputs(), st.integers(1, 2))
def test_screening_does_not_depend_on_thread_count(args, threads):
    mu, sigma, y, t, c = args
    before = edmf_rs.get_num_threads()
    try:
        edmf_rs.set_num_threads(threads)
        a = screen(mu, sigma, y, t, c)[0]
        edmf_rs.set_num_threads(3 - threads)
        b = screen(mu, sigma, y, t, c)[0]
    finally:
        edmf_rs.set_num_threads(before)
    np.testing.assert_array_equal(a, b)


@given(screening_inputs())
def test_zero_sigma_is_eq_8_on_the_mean(args):
    mu, _, y, t, _ = args
    kept, _ = screen(mu, np.zeros_like(mu), y, t, 3.0)
    np.testing.assert_array_equal(kept, reference.falsify(mu, y, t).candidate_indices)


@given(screening_inputs())
def test_required_margin_agrees_with_the_rule(args):
    mu, sigma, y, t, c = args
    need = required_margin(mu, sigma, y, t)
    kept = screen_reference(mu, sigma, y, t, c)
    # Away from the last bit at the boundary, c >= need keeps the point.
    clear = np.abs(need - c) > 1e-9 * (1 + c)
    mask = np.zeros(mu.shape[0], bool)
    mask[kept] = True
    np.testing.assert_array_equal(mask[clear], (need <= c)[clear])


def test_bad_arguments_name_what_was_expected():
    t = edmf_rs.Thresholds([-1.0, -1.0], [1.0, 1.0])
    mu = np.zeros((4, 2))
    with pytest.raises(ValueError, match="sigma: standard deviations >= 0"):
        screen(mu, -np.ones((4, 2)), [0, 0], t)
    with pytest.raises(ValueError, match="sigma: expected the shape of mu"):
        screen(mu, np.zeros((4, 3)), [0, 0], t)
    with pytest.raises(ValueError, match="mu: expected 2 columns"):
        screen(np.zeros((4, 3)), np.zeros((4, 3)), [0, 0], t)
    with pytest.raises(ValueError, match="c: expected a finite number >= 0"):
        screen(mu, mu, [0, 0], t, c=-1)
    with pytest.raises(ValueError, match="measurements"):
        screen(mu, mu, [0, 0, 0], t)
    with pytest.raises(TypeError, match="thresholds"):
        screen(mu, mu, [0, 0], (-1, 1))
