"""Prognosis: a quantity of interest over the candidate model set."""

from pathlib import Path

import edmf_rs
import numpy as np
import pytest
from edmf_rs.project import Project
from edmf_rs.project.prognosis import predict
from scipy import stats

THETA = np.array([[1.0, 2.0], [3.0, -1.0], [2.0, 0.5]])
Z90 = 1.6448536269514722  # standard normal 95th percentile


def qoi(theta):
    return theta[:, 0] * 2.0 + theta[:, 1]  # 4, 5, 4.5


def test_range_without_uncertainty_is_the_candidates_range():
    p = predict(qoi, THETA, name="q")
    np.testing.assert_array_equal(p.values, [4.0, 5.0, 4.5])
    assert (p.low, p.high, p.model_low, p.model_high) == (4.0, 5.0, 4.0, 5.0)


def test_normal_uncertainty_with_the_sign_of_eq_4():
    # model error eps ~ N(1, 2): true = q - eps; central 90 % interval of eps is [1 - 2 z, 1 + 2 z]
    p = predict(qoi, THETA, uncertainty=stats.norm(1.0, 2.0), probability=0.90, name="q", unit="mm")
    assert p.uncertainty_interval == pytest.approx((1 - 2 * Z90, 1 + 2 * Z90))
    assert p.low == pytest.approx(4.0 - (1 + 2 * Z90))
    assert p.high == pytest.approx(5.0 - (1 - 2 * Z90))
    assert p.summary().startswith("q: ") and "mm" in p.summary()


def test_asymmetric_uniform_uncertainty():
    # eps ~ U(-1, 4): the 95 % central interval is [-1 + 0.125, 4 - 0.125]
    p = predict(qoi, THETA, uncertainty=stats.uniform(-1.0, 5.0), probability=0.95)
    assert p.low == pytest.approx(4.0 - 3.875) and p.high == pytest.approx(5.0 + 0.875)


@pytest.mark.parametrize("theta, qoi_model, message", [
    (np.empty((0, 2)), qoi, "no candidate models"),
    (THETA, lambda t: t, r"returned shape \(3, 2\)"),
    (THETA, lambda t: np.array([1.0, np.nan, 2.0]), "returned nan for candidate 1"),
])
def test_bad_prognosis(theta, qoi_model, message):
    with pytest.raises(ValueError, match=message):
        predict(qoi_model, theta)


def test_complex_values_are_refused_not_cast_to_their_real_part():
    with pytest.raises(TypeError, match="QoI model's values: expected real numbers, got dtype complex128"):
        predict(lambda t: t[:, 0] + 1j, THETA)


def test_uncertainty_must_be_a_scalar_frozen_distribution():
    with pytest.raises(TypeError, match="scalar frozen"):
        predict(qoi, THETA, uncertainty=stats.norm([0, 1], 1))


def test_identification_predict_on_the_cantilever():
    path = Path(edmf_rs.__file__).parent / "examples" / "projects" / "cantilever.toml"
    ident = Project.from_toml(path).run(progress=False)
    E = ident.candidates["E"].to_numpy()
    q = 2 * 5e3 * 3000.0**3 / (3 * E * 6.75e8)  # tip deflection F l^3 / (3 E I) under 2F
    p = ident.predict(lambda t: 2 * 5e3 * 3000.0**3 / (3 * t[:, 0] * 6.75e8), stats.norm(0.0, 0.1), name="tip")
    assert p.model_low == pytest.approx(q.min()) and p.model_high == pytest.approx(q.max())
    z = stats.norm.ppf(0.975)
    assert p.low == pytest.approx(q.min() - 0.1 * z) and p.high == pytest.approx(q.max() + 0.1 * z)
    # the project's own [[prognosis]] (N(-0.19, 0.29)) follows the same rule
    shipped = ident.prognoses[0]
    assert shipped.low == pytest.approx(q.min() - (-0.19 + 0.29 * z))
    assert shipped.high == pytest.approx(q.max() - (-0.19 - 0.29 * z))
