"""Expected identifiability (Rust) against the NumPy reference, on the same draws."""

import edmf_rs
import numpy as np
import pytest
from edmf_rs import design
from edmf_rs.design import reference as ref
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats


@st.composite
def cases(draw):
    n = draw(st.integers(1, 60))
    n_loc = draw(st.integers(1, 6))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if draw(st.booleans()):
        g = rng.integers(0, 4, size=(n, n_loc)).astype(np.float64)  # ties and values on bounds
    else:
        g = rng.normal(size=(n, n_loc)) * rng.uniform(0.1, 3, size=n_loc)
    g = g.astype(draw(st.sampled_from([np.float64, np.float32])))
    sd = rng.uniform(0.05, 1.0, size=n_loc)
    if draw(st.booleans()):
        combined = edmf_rs.combine(measurement=[stats.norm(0, sd)])
    else:
        combined = edmf_rs.combine(model=[stats.uniform(-sd, 2 * sd)], n_samples=2000, seed=1)
    m = draw(st.integers(1, n_loc))
    sensors = rng.permutation(n_loc)[:m].tolist()
    return g, combined, sensors, draw(st.integers(0, 1000))


@given(cases())
def test_sizes_match_the_reference_on_the_same_draws(case):
    g, combined, sensors, seed = case
    r = design.expected_identifiability(g, combined, sensors, n_simulations=40, seed=seed)
    expected = ref.expected_identifiability(g, combined, sensors, n_simulations=40, seed=seed)
    np.testing.assert_array_equal(r.sizes, expected)
    assert r.sizes.min() >= 0 and r.sizes.max() <= g.shape[0]


def test_candidate_counts_on_bounds_are_inclusive():
    g = np.array([[0.0], [1.0], [2.0], [3.0]])
    truth = np.array([1], dtype=np.uint64)
    residuals = np.zeros((1, 1))
    # y = 1; residual g - y in [-1, 1] keeps instances 0, 1, 2 (bounds included).
    sizes = edmf_rs._core.design_candidate_counts(g, [0], truth, residuals, np.array([-1.0]), np.array([1.0]))
    assert sizes.tolist() == [3]
    assert ref.candidate_counts(g, [0], truth, residuals, np.array([-1.0]), np.array([1.0])).tolist() == [3]


def test_curve_points_equal_single_sets_and_sidak_widens():
    rng = np.random.default_rng(3)
    g = rng.normal(size=(400, 5))
    combined = edmf_rs.combine(measurement=[stats.norm(0, 0.4)], n_sensors=5)
    curve = design.identifiability_curve(g, combined, [4, 2, 0], n_simulations=60, seed=5)
    for m in (1, 2, 3):
        single = design.expected_identifiability(g, combined, [4, 2, 0][:m], n_simulations=60, seed=5)
        np.testing.assert_array_equal(curve.sizes[m - 1], single.sizes)
    # A second sensor that repeats the first (same predictions, same residual
    # draws) is no new information, but Sidak widens the bounds of both: the
    # candidate sets can only grow.
    dup = np.column_stack([g[:, 0], g[:, 0]])
    s = np.random.default_rng(2).normal(0, 0.4, size=5000)
    c2 = edmf_rs.CombinedUncertainty(2, samples=np.column_stack([s, s]))
    one = design.expected_identifiability(dup, c2, [0], n_simulations=80, seed=1)
    two = design.expected_identifiability(dup, c2, [0, 1], n_simulations=80, seed=1)
    assert np.all(two.sizes >= one.sizes) and two.mean > one.mean


def test_summary_fractions():
    g = np.linspace(0, 10, 101)[:, None]
    u = edmf_rs.combine(measurement=[stats.norm(0, 0.5)], n_sensors=1)
    r = design.expected_identifiability(g, u, [0], n_simulations=100)
    s = r.summary()
    assert s["mean_fraction"] == pytest.approx(r.sizes.mean() / 101)
    assert s["p95"] == np.percentile(r.sizes, 95)


def test_bad_input():
    g = np.zeros((5, 3))
    u = edmf_rs.combine(measurement=[stats.norm(0, 1)], n_sensors=3)
    with pytest.raises(ValueError, match="^sensors:"):
        design.expected_identifiability(g, u, [0, 0])
    with pytest.raises(ValueError, match="^sensors:"):
        design.expected_identifiability(g, u, [3])
    with pytest.raises(ValueError, match="^combined:"):
        design.expected_identifiability(g, edmf_rs.combine(measurement=[stats.norm(0, 1)], n_sensors=2), [0])
    with pytest.raises(ValueError, match="^n_simulations:"):
        design.expected_identifiability(g, u, [0], n_simulations=0)


def _project_combined(names, n_samples):
    """A mixed U_c as a project makes it (named locations, exact marginals kept)."""
    from edmf_rs.project.sources import UncertaintySource, combine_sources

    sources = (
        UncertaintySource("noise", "measurement", "normal", (0.0, 0.1), "absolute", (0, 1, 2)),
        UncertaintySource("m", "model", "normal", (0.0, 1.0), "absolute", (0, 1, 2)),
        UncertaintySource("n2", "model", "normal", (0.0, 0.5), "absolute", (0,)),
        UncertaintySource("u", "model", "uniform", (-1.0, 1.0), "absolute", (1, 3)),
        UncertaintySource("c", "model", "cauchy", (), "absolute", (2,), (("loc", 0.0), ("scale", 0.1))),
    )
    return combine_sources(sources, np.ones(4), n_samples=n_samples, seed=3, sensor_names=names)


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("sensors", [[0], [1, 0], [2, 0, 1], [3, 1], [0, 1, 2, 3]])
@pytest.mark.parametrize("correction", ["sidak", "bonferroni"])
def test_subset_bounds_are_the_full_bounds_of_those_sensors(sensors, correction):
    from edmf_rs.design.identifiability import subset
    from edmf_rs.engine.thresholds import sensor_probability

    combined = _project_combined(("A", "B", "C", "D"), 20_000)
    assert combined.exact_sensors.tolist() == [True, False, False, True]
    sub = edmf_rs.threshold_bounds(subset(combined, sensors), phi=0.95, correction=correction)
    p = sensor_probability(0.95, len(sensors), correction)
    full = edmf_rs.threshold_bounds(combined, phi=p, correction="none")
    np.testing.assert_array_equal(sub.low, full.low[sensors])
    np.testing.assert_array_equal(sub.high, full.high[sensors])
    assert sub.method == tuple(full.method[j] for j in sensors)
    assert sub.probability == p


def test_all_normal_sensors_of_a_mixed_uncertainty_get_exact_bounds():
    """repro: two all-normal locations of a U_c with a Monte Carlo one had Monte Carlo bounds."""
    from edmf_rs.design.identifiability import subset

    comb = edmf_rs.combine(model=[[stats.norm(0, 1), stats.norm(0, 1), stats.uniform(-1, 2)]],
                           measurement=[stats.norm(0, 0.1)], n_samples=20_000)
    t = edmf_rs.threshold_bounds(subset(comb, [0, 1]), phi=0.95)
    exact = stats.norm(0, np.hypot(1, 0.1)).ppf(0.5 + 0.95 ** 0.5 / 2)
    np.testing.assert_allclose(t.high, [exact, exact], rtol=1e-12)
    np.testing.assert_allclose(t.low, [-exact, -exact], rtol=1e-12)
    assert t.method == ("exact", "exact")


def test_thin_tail_warnings_name_the_locations_not_subset_positions():
    from edmf_rs.design.identifiability import subset

    combined = _project_combined(("A", "B", "C", "D"), 2_000)  # few samples: C's bounds warn
    with pytest.warns(UserWarning, match=r"combined: sensor C: about") as caught:
        edmf_rs.threshold_bounds(subset(combined, [2, 0]), phi=0.95)
    assert not any("sensor 0" in str(w.message) for w in caught)
    unnamed = _project_combined(None, 2_000)
    with pytest.warns(UserWarning, match=r"combined: sensor 2: about"):
        edmf_rs.threshold_bounds(subset(unnamed, [2, 0]), phi=0.95)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_expected_identifiability_uses_the_full_bounds_of_its_sensors():
    """The sizes are those of Eq. 8 with each sensor's bounds in the full U_c (the falsification's)."""
    from edmf_rs.engine.thresholds import sensor_probability

    combined = _project_combined(("A", "B", "C", "D"), 20_000)
    g = np.random.default_rng(0).normal(size=(400, 4)) * 3
    sensors = [2, 0, 1]
    r = design.expected_identifiability(g, combined, sensors, n_simulations=300, seed=5)
    full = edmf_rs.threshold_bounds(combined, phi=sensor_probability(0.95, 3, "sidak"), correction="none")
    truth, residuals = ref.draw_simulations(combined, 400, 300, 5)
    expected = ref.candidate_counts(g, sensors, truth, residuals[:, sensors], full.low[sensors], full.high[sensors])
    np.testing.assert_array_equal(r.sizes, expected)


def test_subset_takes_every_field_of_the_combined_uncertainty():
    """A field added to CombinedUncertainty must be taken per location by subset (or be one for all):
    this list is what subset handles."""
    import dataclasses

    from edmf_rs.design.identifiability import subset
    from edmf_rs.engine.uncertainty import CombinedUncertainty

    per_location = {"n_sensors", "distribution", "samples", "marginals", "symmetric", "gaussian", "sensor_names",
                    "sources"}
    shared = {"seed"}
    assert {f.name for f in dataclasses.fields(CombinedUncertainty)} == per_location | shared
    combined = _project_combined(("A", "B", "C", "D"), 2_000)
    sub = subset(combined, [3, 1])
    assert sub.n_sensors == 2 and sub.samples.shape == (2_000, 2) and sub.seed == combined.seed
    np.testing.assert_array_equal(sub.samples, combined.samples[:, [3, 1]])
    assert sub.marginals == (combined.marginals[3], combined.marginals[1])
    assert sub.sources == (combined.sources[3], combined.sources[1])
    assert sub.symmetric.tolist() == combined.symmetric[[3, 1]].tolist()
    assert sub.gaussian.tolist() == combined.gaussian[[3, 1]].tolist()
    assert sub.sensor_names == ("D", "B")
