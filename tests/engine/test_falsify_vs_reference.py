"""The Rust falsification kernel against the plain NumPy reference (Eq. 8),
on broadly generated inputs: dtypes, memory layouts, chunkings, thread counts,
residuals lying exactly on a bound, and NaN predictions."""

import edmf_rs
import numpy as np
import pytest
from edmf_rs import reference
from hypothesis import given
from hypothesis import strategies as st

FIELDS = ("n_instances", "n_invalid")
ARRAYS = ("candidate_indices", "per_sensor_falsified", "falsified_only_by", "n_violated")


def assert_same(result, expected):
    for f in FIELDS:
        assert getattr(result, f) == getattr(expected, f), f
    for f in ARRAYS:
        np.testing.assert_array_equal(getattr(result, f), getattr(expected, f), err_msg=f)
    np.testing.assert_array_equal(result.candidate_mask, expected.candidate_mask)
    assert result.model_class_falsified == (expected.candidate_indices.size == 0)


@st.composite
def problems(draw):
    n = draw(st.integers(0, 300))
    # Up to 210: f32 rows of 65-128 take the medium kernels (two words of
    # verdict bits a row), as do f64 rows of 65-96 and f32 rows of 129-200 at
    # AVX2 (four words); longer rows (and f64 rows past 64 at AVX-512) the
    # long-row ones.
    n_m = draw(st.one_of(st.integers(1, 7), st.integers(8, 80), st.integers(81, 210)))
    dtype = draw(st.sampled_from([np.float64, np.float32]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    y = rng.normal(0.0, 1.0, n_m)
    # Coarse values make exact ties frequent; bounds are taken from actual residuals.
    grid = draw(st.sampled_from([None, 0.25]))
    base = rng.normal(0.0, 1.0, (n, n_m)) + y
    if draw(st.booleans()):  # sparse: about one large residual per row, at any sensor
        base = np.where(rng.random((n, n_m)) < 1.0 / n_m, base, y + rng.normal(0.0, 0.05, (n, n_m)))
    if grid:
        base = np.round(base / grid) * grid
    predictions = base.astype(dtype)
    residuals = predictions.astype(np.float64) - y
    low = rng.uniform(-1.5, -0.2, n_m)
    high = rng.uniform(0.2, 1.5, n_m)
    if n and draw(st.booleans()):  # put bounds exactly on some residuals
        rows = rng.integers(0, n, size=2)
        low = np.minimum(residuals[rows[0]], residuals[rows[1]])
        high = np.maximum(residuals[rows[0]], residuals[rows[1]])
    if n and draw(st.booleans()):
        predictions[rng.integers(0, n, size=3), rng.integers(0, n_m, size=3)] = np.nan
    layout = draw(st.sampled_from(["C", "F", "strided", "reversed"]))
    if layout == "F":
        predictions = np.asfortranarray(predictions)
    elif layout == "strided":
        wide = np.zeros((2 * n, 3 * n_m), dtype=dtype)
        wide[::2, ::3] = predictions
        predictions = wide[::2, ::3]
    elif layout == "reversed":
        predictions = predictions[::-1][::-1, ::-1][:, ::-1]
    thresholds = edmf_rs.Thresholds(low, high)
    return predictions, y, thresholds


@given(problem=problems(), threads=st.sampled_from([1, 2]), chunk_rows=st.one_of(st.none(), st.integers(1, 97)))
def test_falsify_matches_reference(problem, threads, chunk_rows):
    predictions, y, thresholds = problem
    edmf_rs.set_num_threads(threads)
    try:
        result = edmf_rs.falsify(predictions, y, thresholds, chunk_rows=chunk_rows)
    finally:
        edmf_rs.set_num_threads(2)
    assert_same(result, reference.falsify(predictions, y, thresholds))


@given(problem=problems(), splits=st.lists(st.integers(0, 300), max_size=5))
def test_streamed_chunks_match_reference(problem, splits):
    predictions, y, thresholds = problem
    cuts = sorted({min(s, predictions.shape[0]) for s in splits})
    chunks = np.split(predictions, cuts)
    result = edmf_rs.falsify(iter(chunks), y, thresholds)
    assert_same(result, reference.falsify(predictions, y, thresholds))


@given(problem=problems())
def test_screening_gives_the_same_candidates(problem):
    predictions, y, thresholds = problem
    result = edmf_rs.falsify(predictions, y, thresholds, diagnostics=False)
    np.testing.assert_array_equal(result.candidate_indices,
                                  reference.falsify(predictions, y, thresholds).candidate_indices)
    assert result.per_sensor_falsified is None and result.n_violated is None


@st.composite
def edge_problems(draw):
    """Predictions on the rounded edges y + low, y + high and one or two floats
    either side, where the kernels' acceptance intervals must round exactly
    like the residual test; rows long enough for the vector and block paths."""
    n = draw(st.integers(1, 200))
    n_m = draw(st.sampled_from([1, 3, 8, 9, 16, 17, 31, 33, 50]))
    dtype = draw(st.sampled_from([np.float64, np.float32]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scale = 10.0 ** draw(st.integers(-6, 6))
    y = rng.normal(0.0, scale, n_m)
    low = -rng.uniform(0.0, 1e-3, n_m) * scale
    high = rng.uniform(0.0, 1e-3, n_m) * scale
    edge = np.where(rng.random((n, n_m)) < 0.5, y + low, y + high).astype(dtype)
    steps = rng.integers(-2, 3, (n, n_m))
    toward = np.where(steps > 0, np.inf, -np.inf).astype(dtype)
    predictions = edge.copy()
    for _ in range(2):
        moving = np.abs(steps) > 0
        predictions[moving] = np.nextafter(predictions[moving], toward[moving])
        steps = steps - np.sign(steps)
    inside = rng.random(n) < 0.5  # some rows wholly near the measurement, so candidates exist
    predictions[inside] = y.astype(dtype)
    return predictions, y, edmf_rs.Thresholds(low, high)


@given(problem=edge_problems(), diagnostics=st.booleans())
def test_floats_next_to_the_bounds_match_reference(problem, diagnostics):
    predictions, y, thresholds = problem
    result = edmf_rs.falsify(predictions, y, thresholds, diagnostics=diagnostics)
    expected = reference.falsify(predictions, y, thresholds)
    if diagnostics:
        assert_same(result, expected)
    else:
        np.testing.assert_array_equal(result.candidate_indices, expected.candidate_indices)


def test_npy_file_matches_in_memory(tmp_path):
    rng = np.random.default_rng(7)
    y = rng.normal(size=5)
    thresholds = edmf_rs.Thresholds(np.full(5, -1.0), np.full(5, 1.0))
    for order, dtype in (("C", np.float64), ("F", np.float32), ("C", ">f8"), ("C", np.int16)):
        predictions = np.asarray(rng.normal(size=(5000, 5)) + y, order=order).astype(dtype)
        path = tmp_path / f"p-{order}-{np.dtype(dtype).str}.npy"
        np.save(path, predictions)
        result = edmf_rs.falsify(path, y, thresholds, chunk_rows=333)
        expected = reference.falsify(predictions, y, thresholds)
        np.testing.assert_array_equal(result.candidate_indices, expected.candidate_indices)
        np.testing.assert_array_equal(result.per_sensor_falsified, expected.per_sensor_falsified)
        assert result.n_violated is None  # files do not keep an N-long array by default


def test_zero_instances_give_an_empty_result():
    thresholds = edmf_rs.Thresholds([-1.0, -1.0], [1.0, 1.0])
    result = edmf_rs.falsify(np.empty((0, 2)), [0.0, 0.0], thresholds)
    assert result.n_instances == 0 and result.n_candidates == 0
    assert result.model_class_falsified
    assert result.candidate_mask.shape == (0,)
    assert "no model instance was given" in result.summary()


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize("n_m", [17, 33, 34, 40, 64, 65, 80])
def test_a_single_rejecting_sensor_is_named_at_every_position(n_m, dtype):
    # Row j is rejected by sensor j alone; the last row by none.
    p = np.zeros((n_m + 1, n_m), dtype=dtype)
    p[np.arange(n_m), np.arange(n_m)] = 5.0
    t = edmf_rs.Thresholds(-np.ones(n_m), np.ones(n_m))
    for diagnostics in (True, False):
        r = edmf_rs.falsify(p, np.zeros(n_m), t, diagnostics=diagnostics, progress=False)
        assert r.candidate_indices.tolist() == [n_m]
    r = edmf_rs.falsify(p, np.zeros(n_m), t, progress=False)
    np.testing.assert_array_equal(r.falsified_only_by, np.ones(n_m))
    np.testing.assert_array_equal(r.per_sensor_falsified, np.ones(n_m))


def test_leave_one_sensor_out_counts():
    # Sensor 1 alone rejects instance 0; instance 1 is rejected by both; 2 is a candidate.
    p = np.array([[0.0, 5.0], [5.0, 5.0], [0.0, 0.0]])
    r = edmf_rs.falsify(p, [0.0, 0.0], edmf_rs.Thresholds([-1.0, -1.0], [1.0, 1.0]))
    np.testing.assert_array_equal(r.per_sensor_falsified, [1, 2])
    np.testing.assert_array_equal(r.candidates_without_sensor, [1, 2])
    np.testing.assert_array_equal(r.n_violated, [1, 2, 0])


@pytest.mark.parametrize("threads", [1, 2])
def test_large_run_is_deterministic_across_threads(threads):
    rng = np.random.default_rng(3)
    p = rng.normal(size=(300_000, 12)).astype(np.float32)
    thresholds = edmf_rs.Thresholds(np.full(12, -2.5), np.full(12, 2.5))
    edmf_rs.set_num_threads(threads)
    try:
        r = edmf_rs.falsify(p, np.zeros(12), thresholds)
    finally:
        edmf_rs.set_num_threads(2)
    expected = reference.falsify(p, np.zeros(12), thresholds)
    assert_same(r, expected)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_rows_of_two_words_are_attributed_at_every_sensor(dtype):
    # Rows of 60-130 sensors (a row's verdict string crosses 64 bits): row r is
    # rejected by sensor r % n_m alone, or by it and the next (one of them
    # NaN), or by none; every sensor is the first, the only and a later one.
    for n_m in (60, 64, 65, 66, 72, 95, 96, 100, 127, 128, 129, 130):
        n = 3 * n_m + 7
        p = np.zeros((n, n_m), dtype=dtype)
        rows = np.arange(n)
        alone = rows[rows % 3 == 0]
        p[alone, (alone // 3) % n_m] = 5.0
        both = rows[rows % 3 == 1]
        p[both, (both // 3) % n_m] = -5.0
        p[both, (both // 3 + 1) % n_m] = np.nan
        t = edmf_rs.Thresholds(-np.ones(n_m), np.ones(n_m))
        expected = reference.falsify(p, np.zeros(n_m), t)
        assert expected.n_candidates == n - 2 * (n // 3) - (n % 3 > 0) - (n % 3 > 1)
        assert np.all(expected.falsified_only_by > 0) and expected.n_invalid > 0
        assert_same(edmf_rs.falsify(p, np.zeros(n_m), t, progress=False), expected)
