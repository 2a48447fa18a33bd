"""Candidates kept as a bitmap where dense and as indices where sparse
(``rust/src/candidates.rs``), turned into indices only on access: the result's
indices, count and mask equal the NumPy reference's for any density pattern,
chunking and thread count, and survive pickling (the Dask path)."""

import pickle

import edmf_rs
import numpy as np
import pytest
from edmf_rs import reference
from edmf_rs.engine.candidate_set import CandidateSegments, LazyIndices
from hypothesis import given, settings
from hypothesis import strategies as st


@st.composite
def stretches(draw):
    """Predictions whose candidate density changes stretch by stretch (all,
    none, one in 100, one in 2): bitmap and index segments side by side."""
    n_m = draw(st.integers(1, 12))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    parts = []
    for _ in range(draw(st.integers(1, 5))):
        rows = draw(st.sampled_from([1, 63, 64, 65, 1000, 1024, 5000, 70_000]))
        share = draw(st.sampled_from([0.0, 0.01, 0.5, 1.0]))
        block = np.where(rng.random((rows, 1)) < share, 0.0, 5.0) * (rng.random((rows, n_m)) < 0.7)
        parts.append(block + rng.uniform(-0.5, 0.5, (rows, n_m)))
    return np.concatenate(parts), n_m


@settings(max_examples=40, deadline=None)
@given(stretches(), st.sampled_from([None, 1, 777, 4096, 65_536]), st.sampled_from([1, 2]),
       st.booleans(), st.sampled_from([np.float64, np.float32]))
def test_candidates_equal_the_reference_whatever_the_density(problem, chunk_rows, threads, diagnostics, dtype):
    p, n_m = problem
    p = p.astype(dtype)
    y, t = np.zeros(n_m), edmf_rs.Thresholds(low=[-1.0] * n_m, high=[1.0] * n_m)
    expected = reference.falsify(p, y, t)
    before = edmf_rs.get_num_threads()
    edmf_rs.set_num_threads(threads)
    try:
        got = edmf_rs.falsify(p, y, t, diagnostics=diagnostics, chunk_rows=chunk_rows, progress=False)
    finally:
        edmf_rs.set_num_threads(before)
    assert got.n_candidates == expected.n_candidates  # counted from the bits
    np.testing.assert_array_equal(got.candidate_mask, expected.candidate_mask)
    assert got.candidate_indices.dtype == np.int64 and not got.candidate_indices.flags.writeable
    np.testing.assert_array_equal(got.candidate_indices, expected.candidate_indices)


def test_indices_are_formed_only_when_read_and_once():
    p = np.zeros((100_000, 3))
    t = edmf_rs.Thresholds(low=[-1.0] * 3, high=[1.0] * 3)
    r = edmf_rs.falsify(p, np.zeros(3), t, progress=False)
    raw = LazyIndices.raw(r)
    assert isinstance(raw, CandidateSegments)
    assert sum(w.nbytes for _, _, w in raw.segments) == 8 * -(-100_000 // 64)  # a bitmap, not 800 kB of indices
    assert r.n_candidates == 100_000 and r.candidate_mask.all()
    assert isinstance(LazyIndices.raw(r), CandidateSegments)  # count and mask did not form them
    first = r.candidate_indices
    assert first is r.candidate_indices
    np.testing.assert_array_equal(first, np.arange(100_000))
    with pytest.raises(AttributeError):
        r.candidate_indices = first  # still frozen


def test_a_result_with_lazy_candidates_pickles_and_concatenates():
    rng = np.random.default_rng(5)
    p = rng.uniform(-1.2, 1.2, (30_000, 2))
    t = edmf_rs.Thresholds(low=[-1.0] * 2, high=[1.0] * 2)
    parts = [edmf_rs.falsify(p[:10_000], np.zeros(2), t, progress=False),
             edmf_rs.falsify(p[10_000:], np.zeros(2), t, progress=False)]
    back = pickle.loads(pickle.dumps(parts[1]))
    assert isinstance(LazyIndices.raw(back), CandidateSegments)
    whole = edmf_rs.concatenate([parts[0], back])
    np.testing.assert_array_equal(whole.candidate_indices, reference.falsify(p, np.zeros(2), t).candidate_indices)


def test_segments_by_hand():
    words = np.array([2**64 - 1, 0b101], np.uint64)
    s = CandidateSegments([np.array([3], np.uint64), (10, 67, words), np.array([100, 200], np.uint64)])
    want = [3] + list(range(10, 74)) + [74, 76] + [100, 200]
    assert s.count == len(want)
    assert s.indices().tolist() == want
    assert np.flatnonzero(s.mask(201)).tolist() == want
    assert CandidateSegments([]).indices().tolist() == []


def test_a_bitmap_segment_is_counted_without_numpy_bitwise_count(monkeypatch):
    # NumPy 1.26 (the oldest the package allows) has no np.bitwise_count: the count falls back to unpacking
    words = np.array([0b1011, 2**63 + 1, 0], dtype="<u8")
    counted = CandidateSegments([(0, 192, words)]).count
    if hasattr(np, "bitwise_count"):
        monkeypatch.delattr(np, "bitwise_count")
    assert CandidateSegments([(0, 192, words)]).count == counted == 5
