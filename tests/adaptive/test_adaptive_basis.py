"""Emulators on principal components when sensors are many (issue 16, step 2):
as conservative as one GP per sensor, and the model still decides."""

import edmf_rs
import numpy as np
import pytest
from edmf_rs import reference
from edmf_rs.adaptive.basis import PCAEmulators
from edmf_rs.adaptive.design import sobol_points
from edmf_rs.adaptive.emulator import SensorEmulators
from edmf_rs.adaptive.screen import screen
from hypothesis import given, settings
from hypothesis import strategies as st

W = np.random.default_rng(7).normal(size=(3, 40))  # 40 sensors, linear combinations of 3 latent outputs


def latent(theta):
    a, b = theta[:, 0], theta[:, 1]
    return np.column_stack([np.sin(3 * a) + b, a * b, np.exp(-a) * (1 + 0.5 * b)])


def model(theta):
    return latent(theta) @ W


Y = model(np.array([[0.4, 0.6]]))[0] + np.random.default_rng(3).normal(0, 0.02, 40)
HALF = 0.15 * np.abs(W).sum(axis=0) / 3 + 0.05
THRESHOLDS = edmf_rs.Thresholds(-HALF, HALF)


@pytest.fixture(scope="module")
def fitted():
    u = sobol_points(24, 2, 0)
    return u, SensorEmulators(u, model(u)), PCAEmulators(u, model(u))


def test_three_components_describe_forty_sensors(fitted):
    u, _, pca = fitted
    assert pca.n_components == 3 and pca.basis.shape == (40, 3)
    assert pca.residual_variance.max() < 1e-20
    mu, sd = pca.predict(u)
    np.testing.assert_allclose(mu, model(u), atol=1e-6 * np.abs(model(u)).max())


def test_pca_keeps_every_point_the_per_sensor_emulators_keep(fitted):
    _, per_sensor, pca = fitted
    x = sobol_points(8192, 2, 1)
    kept_s = screen(*per_sensor.predict(x), Y, THRESHOLDS, 3.0)[0]
    kept_p = screen(*pca.predict(x), Y, THRESHOLDS, 3.0)[0]
    assert kept_s.size > 50
    missed = np.setdiff1d(kept_s, kept_p)
    assert missed.size <= 0.01 * kept_s.size, (missed.size, kept_s.size)
    # Screening with the cheap prior bound (predict_for_screening) keeps exactly what the exact deviations keep.
    mu, sd = pca.predict_for_screening(x, Y, THRESHOLDS.low, THRESHOLDS.high, 3.0)
    np.testing.assert_array_equal(screen(mu, sd, Y, THRESHOLDS, 3.0)[0], kept_p)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(2, 6), st.floats(0.9, 0.999))
def test_the_variance_goes_back_to_every_sensor_with_the_truncation_residual(seed, n_latent, variance_kept):
    """sigma_i^2 = s_i^2 (sum_j V_ij^2 sigma_j^2 + r_i), recomputed with NumPy from the components' GPs."""
    rng = np.random.default_rng(seed)
    u = rng.random((15, 2))
    freq = rng.uniform(0.5, 4, size=n_latent)
    f = np.sin(u[:, :1] * freq + u[:, 1:] * freq[::-1])
    g = f @ rng.normal(size=(n_latent, 12)) + rng.normal(0, 1e-3, size=(15, 12))
    em = PCAEmulators(u, g, variance_kept=variance_kept)
    # Independent: standardise, SVD, truncation residual per sensor.
    z = (g - g.mean(axis=0)) / g.std(axis=0)
    _, s, vt = np.linalg.svd(z, full_matrices=False)
    k = int(np.argmax(np.cumsum(s**2) / np.sum(s**2) >= variance_kept - 1e-12)) + 1
    assert em.n_components == k
    v = vt[:k].T
    r = ((z - z @ v @ v.T) ** 2).mean(axis=0)
    np.testing.assert_allclose(em.residual_variance, r, rtol=1e-8, atol=1e-14)
    x = rng.random((50, 2))
    mu_t = np.column_stack([gp.predict(x) for gp in em.latent.models])
    sd_t = np.column_stack([gp.predict(x, return_std=True)[1] for gp in em.latent.models])
    mu, sd = em.predict(x)
    np.testing.assert_allclose(mu, g.mean(axis=0) + g.std(axis=0) * (mu_t @ em.basis.T), rtol=1e-8, atol=1e-8)
    expected = g.std(axis=0) * np.sqrt(sd_t**2 @ (em.basis**2) .T + r)
    np.testing.assert_allclose(sd, expected, rtol=1e-6, atol=1e-10)
    assert (sd <= em.prior_std() * (1 + 1e-9)).all()  # the prior bound holds everywhere


def test_adaptive_waves_on_components_report_no_false_candidate():
    r = edmf_rs.adaptive_falsify(model, [[0, 1], [0, 1]], Y, THRESHOLDS, budget=100, n_initial=24, wave_size=12,
                                 n_screen=8192)  # basis="auto": 40 sensors > 10 -> PCA
    fitted = [w for w in r.waves if w.kind != "final"]
    assert all(w.components == 3 and w.fit_seconds > 0 for w in fitted)
    assert r.n_candidates > 0
    ref = reference.falsify(model(r.falsification.candidate_parameters), Y, THRESHOLDS)
    assert ref.n_candidates == r.n_candidates  # every candidate passes Eq. 8 on its real output
    np.testing.assert_array_equal(reference.falsify(r.run_predictions, Y, THRESHOLDS).candidate_indices,
                                  r.falsification.candidate_indices)
    assert r.as_dict()["waves"][0]["components"] == 3


@pytest.mark.parametrize("kw, match", [(dict(basis="svd"), r"basis: expected 'auto', 'sensors' or 'pca'"),
                                       (dict(variance_kept=0.0), r"variance_kept: expected a share in \(0, 1\]"),
                                       (dict(variance_kept=1.5), r"variance_kept: expected a number in \[0, 1\]")])
def test_bad_basis_options_are_named(kw, match):
    with pytest.raises(ValueError, match=match):
        edmf_rs.adaptive_falsify(model, [[0, 1], [0, 1]], Y, THRESHOLDS, budget=100, **kw)
