"""How sure an empty candidate set is: the margin c the most nearly consistent
screening point would need, and sigma there, come from the emulator's exact
predictive deviation, not from the prior bound the screening uses to reject
points cheaply."""

import warnings

import edmf_rs
import edmf_rs.adaptive.waves as waves
import numpy as np
import pytest


def _model(t):
    return np.column_stack([np.sin(3 * t[:, 0]) + t[:, 1], t[:, 0] * t[:, 1] + 0.2 * np.cos(5 * t[:, 1])])


Y = np.array([1000.0, 0.0])  # far from anything the model gives: the model class is falsified
T = edmf_rs.Thresholds([-0.1, -0.1], [0.1, 0.1])


def _margin(mu, sd):
    """Per point, the smallest c keeping it (plain NumPy: excess over the thresholds / sigma)."""
    r = mu - Y
    excess = np.maximum(T.low - r, r - T.high)
    return np.where(excess <= 0, 0.0, excess / sd).max(axis=1)


def _run(monkeypatch, n_screen, basis="sensors"):
    """The run, and (emulator, screening points) of the last screening."""
    seen = []
    original = waves.emulators

    def spy(*args, **kwargs):
        em = original(*args, **kwargs)
        screening = em.predict_for_screening

        def recorded(u, *rest):
            seen.append((em, np.array(u)))
            return screening(u, *rest)

        em.predict_for_screening = recorded
        return em

    monkeypatch.setattr(waves, "emulators", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = edmf_rs.adaptive_falsify(_model, [[0, 1], [0, 1]], Y, T, budget=100, n_screen=n_screen,
                                          basis=basis)
    em = seen[-1][0]
    u = np.concatenate([points for e, points in seen if e is em])  # the last screening, all its chunks
    return result, em, u


@pytest.mark.parametrize("basis", ["sensors", "pca"])
def test_empty_set_reports_the_exact_margin_and_sigma(monkeypatch, basis):
    result, em, u = _run(monkeypatch, 4096, basis)
    assert result.model_class_falsified
    last = [w for w in result.waves if w.min_required_c is not None][-1]
    assert last.kept_fraction == 0
    mu, sd = em.predict(u)  # the emulator's exact mean and deviation at every screening point
    need = _margin(mu, sd)
    # Every point of a 4096-point sample has its exact deviation checked: the smallest margin is exact.
    assert last.min_required_c == pytest.approx(need.min(), rel=1e-6)
    ratio = (sd / T.width).max(axis=1)
    # The prior bound gave c = 23.9 and sigma up to 209 threshold widths here; the exact sigma is tiny.
    assert last.min_required_c > 1e4
    assert last.sigma_ratio <= ratio.max() * (1 + 1e-9)
    assert f"c = {last.min_required_c:.3g}" in result.confidence


def test_empty_set_margin_is_a_real_points_margin_on_a_large_sample(monkeypatch):
    result, em, u = _run(monkeypatch, 12288)  # more points than waves.SPREAD
    last = [w for w in result.waves if w.min_required_c is not None][-1]
    assert last.kept_fraction == 0 and u.shape[0] == 12288
    mu, sd = em.predict(u)
    need = _margin(mu, sd)
    # Not every point's deviation is computed, but the margin reported is that of a screening point
    # with its exact deviation: at least the true smallest, and of its order (not the bound's 1e1).
    assert np.isclose(need, last.min_required_c, rtol=1e-6).any()
    assert need.min() * (1 - 1e-9) <= last.min_required_c <= 10 * need.min()
    assert last.sigma_ratio <= (sd / T.width).max() * (1 + 1e-9)
