"""A checkpoint part stores its candidates as a bitmap where that is smaller
than their indices (``stream/parts.py``: one bit per instance against 64 per
candidate), and a run read back from its folder, resumed or not, has exactly
the candidates of the NumPy reference whatever the mix of forms."""

from __future__ import annotations

import json

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds, reference
from hypothesis import given, settings
from hypothesis import strategies as st

N_M = 3


def _chunks(densities, rows, seed):
    """One chunk per density: each row a candidate with about that probability."""
    rng = np.random.default_rng(seed)
    out = []
    for d in densities:
        inside = rng.random(rows) < d
        scale = np.where(inside, 0.5, 3.0)[:, None]  # |r| <= 0.5 always passes; 3.0 almost never does
        chunk = rng.uniform(-1.0, 1.0, (rows, N_M)) * scale
        out.append(chunk)
    return out


def _state(folder):
    return json.loads((folder / "state.json").read_text())


def _interrupted(chunks, stop_at):
    for k, chunk in enumerate(chunks):
        if k == stop_at:
            raise KeyboardInterrupt
        yield chunk


@settings(max_examples=25, deadline=None)
@given(densities=st.lists(st.sampled_from([0.0, 0.004, 0.03, 0.5, 1.0]), min_size=1, max_size=6),
       rows=st.integers(1, 700), stop_at=st.integers(0, 6), diagnostics=st.booleans(),
       seed=st.integers(0, 2**32 - 1))
def test_resumed_runs_with_mixed_forms_give_the_reference_candidates(tmp_path_factory, densities, rows, stop_at,
                                                                     diagnostics, seed):
    folder = tmp_path_factory.mktemp("run") / "ckpt"
    chunks = _chunks(densities, rows, seed)
    y, t = np.zeros(N_M), Thresholds(np.full(N_M, -1.0), np.full(N_M, 1.0))
    kw = dict(diagnostics=diagnostics, keep_violations=diagnostics, checkpoint=folder, checkpoint_every=0,
              progress=False)
    if stop_at < len(chunks):
        with pytest.raises(KeyboardInterrupt):
            edmf_rs.falsify(_interrupted(chunks, stop_at), y, t, **kw)
    got = edmf_rs.falsify(chunks, y, t, **kw)
    want = reference.falsify(np.concatenate(chunks), y, t)
    np.testing.assert_array_equal(got.candidate_indices, want.candidate_indices)
    assert got.n_candidates == want.n_candidates
    np.testing.assert_array_equal(got.candidate_mask, want.candidate_mask)
    if diagnostics:
        np.testing.assert_array_equal(got.n_violated, want.n_violated)
    # Each part in the smaller form: a bitmap iff more than one instance in 64 is a candidate.
    for part in _state(folder)["parts"]:
        smaller = "bitmap" if part["n_candidates"] * 64 > part["n_instances"] else "indices"
        assert part["candidates"] == smaller
    # The finished folder read back gives the same again.
    again = edmf_rs.falsify(chunks, y, t, **kw)
    np.testing.assert_array_equal(again.candidate_indices, want.candidate_indices)


def test_every_instance_a_candidate_costs_one_bit_each(tmp_path):
    n = 1_000_000
    predictions = np.zeros((n, N_M), np.float32)
    y, t = np.zeros(N_M), Thresholds(np.full(N_M, -1.0), np.full(N_M, 1.0))
    folder = tmp_path / "run"
    got = edmf_rs.falsify(predictions, y, t, checkpoint=folder, progress=False)
    assert got.n_candidates == n
    (part,) = _state(folder)["parts"]
    assert part["candidates"] == "bitmap"
    size = (folder / "part-000000.candidates.npy").stat().st_size
    assert n // 8 <= size <= n // 8 + 8 + 128  # the words, padded to 64 bits, and the .npy header
    np.testing.assert_array_equal(got.candidate_indices[[0, -1]], [0, n - 1])
