"""Bad input raises ValueError/TypeError naming the argument and what was
expected; no Rust panic ever reaches Python."""

import os

import edmf_rs
import numpy as np
import pytest
from scipy import stats

T2 = edmf_rs.Thresholds([-1.0, -1.0], [1.0, 1.0])
Y2 = np.array([0.0, 0.0])


@pytest.mark.parametrize(
    "predictions, error, match",
    [
        (np.zeros((4, 3)), ValueError, r"predictions: expected 2 columns"),
        (np.zeros(4), ValueError, r"predictions: expected a 2-D array"),
        (np.zeros((2, 2, 2)), ValueError, r"predictions: expected a 2-D array"),
        (np.array([["a", "b"]]), TypeError, r"predictions: expected a numeric"),
        (np.zeros((2, 2), dtype=object), TypeError, r"predictions: expected a numeric"),
        (np.zeros((2, 2), dtype=complex), TypeError, r"predictions: expected a numeric"),
        (42, TypeError, r"predictions: expected a 2-D array, a path"),
        ([np.zeros((3, 2)), np.zeros((3, 4))], ValueError, r"chunk 1 has 4 columns, expected 2 like the first"),
        ([np.zeros((3, 2)), np.zeros(3)], ValueError, r"chunk 1\).*2-D"),
        # The user's shape is shown, not that of a slice checked in its place.
        (np.zeros((5, 5)), ValueError, r"expected 2 columns .* got shape \(5, 5\)"),
        (np.zeros((2, 2, 4)), ValueError, r"got 3-D shape \(2, 2, 4\)"),
        ([[0.0, 1.0], [0.0]], TypeError, r"predictions: expected a 2-D array of numbers"),
        (iter([np.zeros((1, 2)), [[0.0, 1.0], [0.0]]]), TypeError, r"predictions \(chunk 1\): expected a 2-D array"),
    ],
)
def test_bad_predictions(predictions, error, match):
    with pytest.raises(error, match=match):
        edmf_rs.falsify(predictions, Y2, T2)


@pytest.mark.parametrize(
    "measurements, match",
    [
        ([0.0, np.nan], r"measurements: expected finite values, got nan at sensor 1"),
        ([np.inf, 0.0], r"measurements: expected finite values"),
        ([0.0], r"measurements: expected 2 values"),
        ([], r"measurements: expected at least one sensor"),
    ],
)
def test_bad_measurements(measurements, match):
    with pytest.raises(ValueError, match=match):
        edmf_rs.falsify(np.zeros((3, 2)), measurements, T2)


def test_bad_thresholds():
    with pytest.raises(ValueError, match=r"low: expected low <= high, got low=2.0 > high=1.0 at sensor 1"):
        edmf_rs.Thresholds([0.0, 2.0], [1.0, 1.0])
    with pytest.raises(ValueError, match=r"low: expected finite values"):
        edmf_rs.Thresholds([np.nan], [1.0])
    with pytest.raises(ValueError, match=r"high: expected finite values"):
        edmf_rs.Thresholds([0.0], [np.inf])
    with pytest.raises(ValueError, match=r"high: expected 1 values"):
        edmf_rs.Thresholds([0.0], [1.0, 2.0])
    with pytest.raises(ValueError, match=r"low: expected at least one sensor"):
        edmf_rs.Thresholds([], [])
    with pytest.raises(TypeError, match=r"thresholds: expected edmf_rs.Thresholds"):
        edmf_rs.falsify(np.zeros((3, 2)), Y2, ([-1, -1], [1, 1]))


@pytest.mark.parametrize("phi", [0.0, 1.0, -0.5, 1.5, np.nan])
def test_phi_outside_the_unit_interval(phi):
    with pytest.raises(ValueError, match=r"phi: expected a value in \(0, 1\)"):
        edmf_rs.threshold_bounds(np.zeros((100, 2)), phi=phi)


def test_phi_must_be_a_number():
    with pytest.raises(TypeError, match="phi"):
        edmf_rs.threshold_bounds(np.zeros((100, 2)), phi="0.95")


def test_unknown_correction():
    with pytest.raises(ValueError, match=r"correction: expected one of 'sidak', 'bonferroni', 'none', got 'holm'"):
        edmf_rs.threshold_bounds(np.zeros((100, 2)), correction="holm")


def test_too_few_samples_says_how_many():
    # p = 0.95**(1/10) = 0.99488..., so 1/(1-p) = 195.5: 196 samples are needed.
    with pytest.raises(ValueError, match=r"at least 196 samples are needed"):
        edmf_rs.threshold_bounds(np.random.default_rng(0).normal(size=(150, 10)), phi=0.95, estimator="shortest")
    # The default window holds p with confidence 0.975: it needs P(Binom(n, p) <= n - 2) >= 0.975.
    p = 0.95 ** 0.1
    need = next(n for n in range(2, 10_000) if stats.binom.cdf(n - 2, n, p) >= 0.975)
    with pytest.raises(ValueError, match=rf"at least {need} samples are needed"), pytest.warns(UserWarning):
        edmf_rs.threshold_bounds(np.random.default_rng(0).normal(size=(150, 10)), phi=0.95)


@pytest.mark.parametrize(
    "combined, error, match",
    [
        (np.zeros((100, 0)), ValueError, r"combined: expected at least one sensor"),
        (np.zeros(100), ValueError, r"combined: expected samples of shape"),
        (np.full((100, 1), np.nan), ValueError, r"combined: finite samples"),
        ("normal", TypeError, r"combined: expected"),
        ([stats.norm(), "x"], TypeError, r"combined: expected every element"),
        (stats.norm(np.zeros((2, 2))), ValueError, r"combined: expected a distribution vectorised"),
    ],
)
def test_bad_combined(combined, error, match):
    with pytest.raises(error, match=match):
        edmf_rs.threshold_bounds(combined, phi=0.5)


def test_bad_uncertainty_sources():
    with pytest.raises(TypeError, match=r"model\[0\]: expected frozen scipy.stats"):
        edmf_rs.combine(model=[1.0])
    with pytest.raises(ValueError, match="disagree on the number of sensors"):
        edmf_rs.combine(model=stats.norm(np.zeros(3)), measurement=stats.norm(np.zeros(2)))
    with pytest.raises(ValueError, match="n_sensors"):
        edmf_rs.combine(model=stats.norm(0, 1))
    with pytest.raises(ValueError, match="at least one uncertainty source"):
        edmf_rs.combine()
    with pytest.raises(ValueError, match="n_samples"):
        edmf_rs.combine(model=stats.uniform(0, 1), n_sensors=2, n_samples=0)


def test_bad_thread_count():
    with pytest.raises(ValueError, match="n: expected a number of threads from 1 to"):
        edmf_rs.set_num_threads(0)
    before = edmf_rs.get_num_threads()
    for n in (2**40, 2**70, 64 * (os.cpu_count() or 1) + 1025):  # 2**40 used to never return
        with pytest.raises(ValueError, match=f"n: expected a number of threads from 1 to .*got {n}$"):  # as given
            edmf_rs.set_num_threads(n)
    for n, kind in ((2.5, "float"), ("2", "str"), (None, "NoneType"), (True, "bool"), (np.float64(2), "float64")):
        with pytest.raises(TypeError, match=f"^n: expected an integer number of threads from 1 to .*, got {kind}$"):
            edmf_rs.set_num_threads(n)
    assert edmf_rs.get_num_threads() == before
    edmf_rs.set_num_threads(np.int64(1))  # NumPy integers are integers
    assert edmf_rs.get_num_threads() == 1
    edmf_rs.set_num_threads(before)


def test_core_rejects_what_the_python_layer_would_have_caught():
    # Defence in depth: the extension itself refuses inconsistent arguments.
    from edmf_rs import _core

    with pytest.raises(ValueError, match="measurements"):
        _core.Falsifier(np.zeros(3), np.zeros(2), np.ones(2))
    with pytest.raises(ValueError, match="thresholds"):
        _core.Falsifier(np.zeros(2), np.ones(2), np.zeros(2))
    acc = _core.Falsifier(np.zeros(2), -np.ones(2), np.ones(2))
    with pytest.raises(ValueError, match="width 3"):
        acc.update(np.zeros((4, 3)))
    with pytest.raises(TypeError, match="float64 or float32"):
        acc.update(np.zeros((4, 2), dtype=np.int64))
    with pytest.raises(ValueError, match="probability"):
        _core.shortest_intervals(np.zeros((10, 1)), 1.0)
    with pytest.raises(ValueError, match="covariance"):
        _core.mahalanobis_squared(np.zeros((1, 2)), np.zeros(2), np.array([[1.0, 2.0], [2.0, 1.0]]))


def test_phi_so_close_to_one_that_the_sensor_probability_rounds_to_one():
    with pytest.raises(ValueError, match="phi: .* rounds to 1"):
        edmf_rs.threshold_bounds(stats.norm(np.zeros(50), 1.0), phi=1 - 1e-15)


def test_sensor_probability_needs_a_positive_sensor_count():
    with pytest.raises(ValueError, match="n_sensors"):
        edmf_rs.sensor_probability(0.95, 0)
    with pytest.raises(TypeError, match="n_sensors"):
        edmf_rs.sensor_probability(0.95, True)


def test_a_list_of_distributions_must_hold_scalar_ones():
    with pytest.raises(ValueError, match="element 0 is vectorised"):
        edmf_rs.threshold_bounds([stats.norm([0.0, 0.0], 1.0), stats.norm()], phi=0.9)


def test_discrete_or_foreign_sources_are_type_errors():
    with pytest.raises(TypeError, match="model: expected a frozen scipy.stats continuous"):
        edmf_rs.combine(model=stats.poisson(3), n_sensors=2)
    with pytest.raises(TypeError, match=r"model\[0\]"):
        edmf_rs.combine(model=[stats.poisson(3)], n_sensors=2)


def test_zero_variance_is_caught_and_a_fixed_offset_source_is_allowed():
    with pytest.raises(ValueError, match="standard deviation is zero at sensor 0"):
        edmf_rs.combine(model=stats.norm(0, 0), n_sensors=2)
    # A normal with sd 0 is a known offset: it shifts U_c without widening it.
    c = edmf_rs.combine(model=[stats.norm(0.5, 0.0)], measurement=[stats.norm(0, np.array([1.0, 2.0]))])
    np.testing.assert_allclose(c.mean, [0.5, 0.5])
    np.testing.assert_allclose(c.std, [1.0, 2.0])


def test_a_flat_list_that_looks_per_sensor_warns():
    with pytest.warns(UserWarning, match="must be nested"):
        edmf_rs.combine(model=[stats.norm(0, 1), stats.norm(0, 2)], measurement=stats.norm(np.zeros(2), 1))


def test_reversed_sample_arrays_are_read_correctly():
    rng = np.random.default_rng(0)
    samples = rng.normal(size=(500, 3))
    t = edmf_rs.threshold_bounds(samples[::-1], phi=0.8, estimator="shortest")  # the Rust core reads the view
    want = edmf_rs.threshold_bounds(np.ascontiguousarray(samples[::-1]), phi=0.8, estimator="shortest")
    np.testing.assert_array_equal(t.low, want.low)


@pytest.mark.parametrize("name", ["diagnostics", "progress", "keep_violations"])
@pytest.mark.parametrize("value", ["no", 0, None])
def test_yes_no_options_take_only_booleans(name, value):
    if name == "keep_violations" and value is None:
        value = "yes"  # None means "the default" there
    with pytest.raises(TypeError, match=f"{name}: expected True or False"):
        edmf_rs.falsify(np.zeros((2, 2)), Y2, T2, **{name: value})
    with pytest.raises(TypeError, match=f"{name}: expected True or False"):
        edmf_rs.falsify_model(lambda p: np.zeros((len(p), 2)), np.zeros((2, 1)), Y2, T2, **{name: value})


def test_numpy_booleans_are_booleans():
    r = edmf_rs.falsify(np.zeros((2, 2)), Y2, T2, diagnostics=np.True_, progress=np.False_)
    assert r.n_candidates == 2


def test_checkpoint_every_is_checked_without_a_checkpoint():
    with pytest.raises(ValueError, match="checkpoint_every"):
        edmf_rs.falsify(np.zeros((2, 2)), Y2, T2, checkpoint_every=-1)


@pytest.mark.parametrize(
    "parameters, match",
    [
        (np.array([["a"], ["b"]]), r"parameters: expected real numbers"),
        (np.zeros((2, 1), dtype=complex), r"parameters: expected real numbers"),
        (np.array([[object()]], dtype=object), r"parameters: expected real numbers"),
        (iter([np.zeros((1, 1)), np.zeros((1, 1), dtype=complex)]), r"parameters \(batch 1\): expected real"),
    ],
)
def test_model_parameters_must_be_real_numbers(parameters, match):
    with pytest.raises(TypeError, match=match):
        edmf_rs.falsify_model(lambda p: np.zeros((len(p), 2)), parameters, Y2, T2, progress=False)


def test_on_batch_must_be_callable_before_the_model_runs():
    calls = []

    def model(p):
        calls.append(len(p))
        return np.zeros((len(p), 2))

    with pytest.raises(TypeError, match="on_batch: expected a callable"):
        edmf_rs.falsify_model(model, np.zeros((3, 1)), Y2, T2, on_batch=5)
    assert calls == []


@pytest.mark.parametrize("checkpoint, error, match", [
    ("", ValueError, "checkpoint: expected a folder path, got an empty string"),
    (5, TypeError, "checkpoint: expected a folder path"),
])
def test_bad_checkpoint_folder(checkpoint, error, match):
    with pytest.raises(error, match=match):
        edmf_rs.falsify(np.zeros((2, 2)), Y2, T2, checkpoint=checkpoint)


def test_a_path_given_as_bytes_is_a_file(tmp_path):
    path = tmp_path / "p.npy"
    np.save(path, np.array([[0.0, 0.0], [5.0, 0.0]]))
    r = edmf_rs.falsify(bytes(path), Y2, T2, progress=False)
    assert r.candidate_indices.tolist() == [0]


def test_array_parameters_are_read_in_place(tmp_path):
    # A memory-mapped parameter file is not copied into memory first: the model
    # gets read-only copies of one batch each (issue 12: a model editing theta
    # in place must not change the caller's array), never of the whole file.
    theta = np.lib.format.open_memmap(tmp_path / "theta.npy", mode="w+", dtype=np.float64, shape=(5000, 1))
    theta[:] = 0.0
    seen = []

    def model(batch):
        owner = batch if batch.base is None else batch.base
        seen.append((np.shares_memory(batch, theta), batch.flags.writeable, owner.size))
        return np.zeros((len(batch), 2))

    edmf_rs.falsify_model(model, theta, Y2, T2, batch_size=1000, progress=False)
    assert seen == [(False, False, 1000)] * 5
