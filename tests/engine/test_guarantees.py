"""What the correction guarantees (Sidak for Gaussian U_c, Bonferroni otherwise), and
the README's statements about it checked against runs: P_T as a population value,
the girder's leave-one-out count, Table 1's footnotes, Fig. 8b."""

import json
import re
from pathlib import Path

import edmf_rs
import numpy as np
import pytest
from edmf_rs import cli
from edmf_rs import coverage as cov
from scipy import stats

README = (Path(__file__).resolve().parents[2] / "README.md").read_text(encoding="utf-8")


def test_sidak_is_exact_for_gaussian_and_bonferroni_bounds_the_rest():
    gauss = edmf_rs.threshold_bounds(stats.norm(np.zeros(50), 1.0), phi=0.95)
    assert gauss.gaussian and gauss.guaranteed_probability == pytest.approx(0.95, abs=1e-12)
    c = edmf_rs.combine(model=stats.uniform(-1, 2), measurement=stats.norm(0, 1), n_sensors=50, n_samples=20_000)
    with pytest.warns(UserWarning, match="about 10 of 20,000"):  # few samples per tail at this n_samples
        mc = edmf_rs.threshold_bounds(c, phi=0.95, method="monte-carlo")
    # 1 - n (1 - phi^(1/n)) at phi = 0.95, n = 50
    assert not mc.gaussian and mc.guaranteed_probability == pytest.approx(1 - 50 * (1 - 0.95 ** (1 / 50)))
    assert round(mc.guaranteed_probability, 4) == 0.9487
    assert "0.9487 whatever the dependence" in mc.guarantee() and "confidence 0.975" in mc.guarantee()
    with pytest.warns(UserWarning, match="n_samples >= 200,000"):
        bonf = edmf_rs.threshold_bounds(c, phi=0.95, correction="bonferroni", method="monte-carlo")
    assert bonf.guaranteed_probability == pytest.approx(0.95, abs=1e-12)
    conv = edmf_rs.threshold_bounds(c, phi=0.95)  # the default, numerical convolution: no samples in the bounds
    assert conv.guaranteed_probability == mc.guaranteed_probability and not conv.monte_carlo
    assert "0.9487 whatever the dependence" in conv.guarantee() and "confidence" not in conv.guarantee()
    assert edmf_rs.Thresholds([0.0], [1.0]).guaranteed_probability is None


def test_bonferroni_holds_phi_under_a_dependence_where_sidak_does_not():
    # Two sensors with uniform U_c that are never outside together: the joint miss is the sum of the misses.
    phi, n = 0.9, 2
    u = np.random.default_rng(0).random(400_000)
    samples = np.column_stack([u, (u + 0.5) % 1.0])
    for correction, want in (("sidak", 1 - n * (1 - phi ** (1 / n))), ("bonferroni", phi)):
        p = edmf_rs.sensor_probability(phi, n, correction)
        lo, hi = 0.5 - p / 2, 0.5 + p / 2  # the exact central intervals of U(0, 1)
        inside = np.all((samples >= lo) & (samples <= hi), axis=1).mean()
        assert inside == pytest.approx(want, abs=0.003)
        t = edmf_rs.threshold_bounds([stats.uniform(0, 1)] * n, phi, correction)
        assert t.guaranteed_probability == pytest.approx(want)
    assert 1 - n * (1 - phi ** (1 / n)) < phi  # Sidak alone would promise too much here


def test_project_summary_and_report_state_the_guarantee(tmp_path):
    ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
    text = ident.summary()
    assert "guarantee: joint probability >= 0.9500 whatever the correlation" in text
    d = ident.summary_dict()["identification"]
    assert d["guaranteed_probability"] == pytest.approx(0.95) and d["borderline_instances"] == 0
    table = ident.thresholds_table()
    assert {"threshold_low_se", "threshold_high_se", "method"} <= set(table.columns) and set(table["method"]) == {"exact"}


def test_readme_p_t_is_the_population_value_with_the_noise_of_1000_draws():
    c = stats.norm.ppf(0.5 + 0.5 * 0.95 ** 0.5)
    population = []
    for rho in cov.PAPER_RHO_TRUE:
        mvn = stats.multivariate_normal([0, 0], [[1, rho], [rho, 1]])
        population.append(mvn.cdf([c, c]) - mvn.cdf([-c, c]) - mvn.cdf([c, -c]) + mvn.cdf([-c, -c]))
    shipped = [r.P_T for r in cov.figure3_cases()]
    assert "P_T is " + " / ".join(f"{p:.3f}" for p in population) in README
    assert "print " + " / ".join(f"{p:.3f}" for p in shipped) in README
    many = [r.P_T for r in cov.figure3_cases(n_draws=200_000, seed=1)]
    np.testing.assert_allclose(many, population, atol=4 * np.sqrt(0.05 / 200_000))
    sd = max(np.sqrt(p * (1 - p) / 1000) for p in population)
    assert "about 0.007" in README and round(sd, 3) == 0.007
    np.testing.assert_allclose(shipped, population, atol=2 * sd)


def test_readme_table1_has_the_papers_footnotes():
    assert "| 2. Recognised systematic errors | × | ×¹ | ✓ |" in README
    assert "| 3. Unrecognised errors | × | × | ✓² |" in README
    assert "¹ When uncertainty dependencies are assumed to be independent." in README
    assert "² Provided that a sufficient number of\nmeasurements are used." in README


def test_readme_fig8b_says_how_often_the_candidate_set_is_empty():
    from edmf_rs.examples import cantilever as cl
    from edmf_rs.paper import reproduce

    scenario = next(s for s in cl.SCENARIOS if s.number == 3)
    sizes = np.array([reproduce.identify(scenario, y).falsification.n_candidates
                      for y in reproduce.measurement_draws(scenario, 2, 200, 0)])
    assert sizes[0] == 0 and sizes[1] > 0
    empty = np.mean(sizes == 0)
    assert f"as in {100 * empty:.1f} % of\nthe 200 draws" in README
    assert f"the other {100 * (1 - empty):.1f} %" in README


def test_readme_girder_count_is_what_the_cli_prints(tmp_path, capsys):
    assert cli.main(["run", "--example", "girder", "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    out = capsys.readouterr().out
    printed = int(re.search(r"ignoring it leaves (\d+) candidates", out).group(1))
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    rows = {t["sensor"]: t for t in summary["thresholds"]}
    assert rows["SG5"]["candidates_without_sensor"] == printed
    assert f"leaves {printed} candidates)" in README
