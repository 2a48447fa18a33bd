"""Sec. 3.2 / Fig. 3: the ellipse needs the right correlation, the Sidak rectangle does not."""

import numpy as np
import pytest
from edmf_rs import coverage as cv
from scipy import stats

# Reported in Sec. 3.2 for assumed correlation 0.9 and true 0.9, 0.4, -0.9.
PAPER = [(0.9, 0.95), (0.4, 0.64), (-0.9, 0.42)]


@pytest.fixture(scope="module")
def cases():
    return {r.rho_true: r for r in cv.figure3_cases(n_draws=20_000, seed=2013)}


@pytest.mark.parametrize(("rho_true", "p_m"), PAPER)
def test_ellipse_share_matches_the_paper(cases, rho_true, p_m):
    assert cases[rho_true].P_M == pytest.approx(p_m, abs=0.03)


@pytest.mark.parametrize("rho_true", [0.9, 0.4, -0.9])
def test_rectangle_holds_at_least_phi_whatever_the_correlation(cases, rho_true):
    # 20000 draws: the sampling sd of P_T is about 0.0015.
    assert cases[rho_true].P_T >= 0.95 - 0.005


def test_regions_agree_with_independent_formulas(cases):
    r = cases[0.4]
    # Eq. 6 for N(0, 1) with the Sidak probability 0.95^(1/2).
    z = stats.norm.ppf(0.5 + 0.5 * np.sqrt(0.95))
    assert r.thresholds.high == pytest.approx([z, z]) and r.thresholds.low == pytest.approx([-z, -z])
    assert np.array_equal(r.inside_rectangle, np.all(np.abs(r.draws) <= z, axis=1))
    # Eq. 9 with the assumed correlation, written out for 2 x 2.
    x1, x2, rho = r.draws[:, 0], r.draws[:, 1], 0.9
    d2 = (x1**2 - 2 * rho * x1 * x2 + x2**2) / (1 - rho**2)
    assert r.chi2_bound == pytest.approx(-2 * np.log(0.05))  # chi2(2) quantile in closed form
    assert np.array_equal(r.inside_ellipse, d2 <= r.chi2_bound)


def test_draws_have_the_true_correlation(cases):
    for rho, case in cases.items():
        assert case.draws.shape == (20_000, 2)
        assert np.corrcoef(case.draws.T)[0, 1] == pytest.approx(rho, abs=0.02)
        assert case.draws.std(axis=0) == pytest.approx([1.0, 1.0], abs=0.02)


def test_seeded_runs_are_deterministic():
    a = cv.coverage(0.4, n_draws=500, seed=1)
    b = cv.coverage(0.4, n_draws=500, seed=1)
    assert np.array_equal(a.draws, b.draws) and a.P_M == b.P_M and a.P_T == b.P_T
    assert not np.array_equal(cv.coverage(0.4, n_draws=500, seed=2).draws, a.draws)


@pytest.mark.parametrize(
    ("kwargs", "exc", "name"),
    [
        ({"rho_true": 1.0}, ValueError, "rho_true"),
        ({"rho_true": "0.4"}, TypeError, "rho_true"),
        ({"rho_assumed": -1.5}, ValueError, "rho_assumed"),
        ({"n_draws": 0}, ValueError, "n_draws"),
        ({"phi": 1.2}, ValueError, "phi"),
    ],
)
def test_bad_input_names_the_argument(kwargs, exc, name):
    args = {"rho_true": 0.4} | kwargs
    with pytest.raises(exc, match=name):
        cv.coverage(args.pop("rho_true"), **args)
