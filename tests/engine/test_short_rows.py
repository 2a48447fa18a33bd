"""Short rows (1 to 40 sensors: the packed, one-vector and vector-plus-tail
kernels) against the plain NumPy reference (Eq. 8): f32 and f64; C order,
rows with gaps, every other row, Fortran order and strided columns; NaN and
infinite predictions; all-candidate, all-falsified and mixed blocks longer
than a block of rows; chunkings, thread counts, with and without diagnostics.

tests/test_short_rows_isa.py runs this file again at every instruction-set
level the CPU has (``EDMF_RS_ISA``)."""

import edmf_rs
import numpy as np
from edmf_rs import reference
from hypothesis import given
from hypothesis import strategies as st

ARRAYS = ("candidate_indices", "per_sensor_falsified", "falsified_only_by", "n_violated")


def assert_same(result, expected):
    assert result.n_instances == expected.n_instances
    assert result.n_invalid == expected.n_invalid
    for f in ARRAYS:
        np.testing.assert_array_equal(getattr(result, f), getattr(expected, f), err_msg=f)


def lay_out(predictions, layout):
    """The same values in another memory layout."""
    n, n_m = predictions.shape
    if layout == "F":
        return np.asfortranarray(predictions)
    if layout == "gap":  # C rows with a gap after each (row stride > width)
        wide = np.zeros((n, n_m + 3), dtype=predictions.dtype)
        wide[:, :n_m] = predictions
        return wide[:, :n_m]
    if layout == "every other row":
        wide = np.zeros((2 * n, n_m), dtype=predictions.dtype)
        wide[::2] = predictions
        return wide[::2]
    if layout == "strided columns":
        wide = np.zeros((n, 2 * n_m), dtype=predictions.dtype)
        wide[:, ::2] = predictions
        return wide[:, ::2]
    return np.ascontiguousarray(predictions)


@st.composite
def short_problems(draw):
    n = draw(st.sampled_from([0, 1, 2, 7, 15, 16, 17, 100, 1023, 1024, 1025, 2500]))
    n_m = draw(st.integers(1, 40))
    dtype = draw(st.sampled_from([np.float64, np.float32]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    y = rng.normal(0.0, 1.0, n_m)
    low, high = -rng.uniform(0.2, 1.0, n_m), rng.uniform(0.2, 1.0, n_m)
    # Share of the sensors pushed out of bounds: none (all candidates), a few
    # (mixed: rows rejected by one sensor, by several, or none) or all.
    out_rate = draw(st.sampled_from([0.0, 0.3 / n_m, 1.0 / n_m, 3.0 / n_m, 1.0]))
    inside = y + rng.uniform(0.0, 1.0, (n, n_m)) * (high - low) + low
    outside = y + np.where(rng.random((n, n_m)) < 0.5, low - 0.5, high + 0.5)
    predictions = np.where(rng.random((n, n_m)) < out_rate, outside, inside).astype(dtype)
    if n and draw(st.booleans()):  # exactly on the bounds
        i, j = rng.integers(0, n, 4), rng.integers(0, n_m, 4)
        predictions[i, j] = (y[j] + np.where(rng.random(4) < 0.5, low[j], high[j])).astype(dtype)
    if n and draw(st.booleans()):
        i, j = rng.integers(0, n, 4), rng.integers(0, n_m, 4)
        predictions[i, j] = rng.choice([np.nan, np.inf, -np.inf], 4)
    layout = draw(st.sampled_from(["C", "gap", "every other row", "F", "strided columns"]))
    return lay_out(predictions, layout), y, edmf_rs.Thresholds(low, high)


@given(problem=short_problems(), threads=st.sampled_from([1, 2]),
       chunk_rows=st.one_of(st.none(), st.integers(1, 1500)), diagnostics=st.booleans())
def test_short_rows_match_reference(problem, threads, chunk_rows, diagnostics):
    predictions, y, thresholds = problem
    edmf_rs.set_num_threads(threads)
    try:
        result = edmf_rs.falsify(predictions, y, thresholds, chunk_rows=chunk_rows,
                                 diagnostics=diagnostics, progress=False)
    finally:
        edmf_rs.set_num_threads(2)
    expected = reference.falsify(predictions, y, thresholds)
    if diagnostics:
        assert_same(result, expected)
    else:
        np.testing.assert_array_equal(result.candidate_indices, expected.candidate_indices)
        assert result.per_sensor_falsified is None


def test_packed_rows_are_attributed_at_every_width_and_slot():
    # Row r of each width is rejected by sensor r % n_m alone, or by it and the
    # next one, or by none: every slot of a packed vector, every sensor.
    for dtype in (np.float64, np.float32):
        for n_m in range(1, 41):
            n = 3 * 32 + 5
            p = np.zeros((n, n_m), dtype=dtype)
            rows = np.arange(n)
            p[rows[rows % 3 == 0], (rows[rows % 3 == 0] // 3) % n_m] = 5.0
            both = rows[rows % 3 == 1]
            p[both, (both // 3) % n_m] = -5.0
            p[both, (both // 3 + 1) % n_m] = np.nan
            t = edmf_rs.Thresholds(-np.ones(n_m), np.ones(n_m))
            expected = reference.falsify(p, np.zeros(n_m), t)
            assert expected.n_candidates == n // 3
            for layout in ("C", "gap"):
                q = lay_out(p, layout)
                assert_same(edmf_rs.falsify(q, np.zeros(n_m), t, progress=False), expected)
                r = edmf_rs.falsify(q, np.zeros(n_m), t, diagnostics=False, progress=False)
                np.testing.assert_array_equal(r.candidate_indices, expected.candidate_indices)
