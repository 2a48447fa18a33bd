"""The row digest a checkpoint records is computed by the falsifier in the
same pass as the falsification (``_core.Falsifier.update(chunk, digest=...)``);
it must be exactly the digest of a separate ``_core.RowDigest`` pass, so a
folder made either way resumes the other."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds, _core
from edmf_rs.engine.durable import Durable
from edmf_rs.stream import state as state_file
from hypothesis import given, settings
from hypothesis import strategies as st

BLOCK = _core.RowDigest.block_rows


def _separate(arr):
    d = _core.RowDigest()
    d.update(arr)
    return d.blocks(), d.partial(), d.n_rows


def _run(values, chunk_rows, diagnostics, folder, **options):
    n_m = values.shape[1]
    return edmf_rs.falsify(values, np.zeros(n_m), Thresholds(np.full(n_m, -1.5), np.full(n_m, 1.5)),
                           chunk_rows=chunk_rows, diagnostics=diagnostics, checkpoint=folder,
                           checkpoint_every=0, progress=False, **options)


@settings(max_examples=12, deadline=None)
@given(n=st.integers(0, BLOCK + 3 * 1024 + 9), n_m=st.integers(1, 70), chunk_rows=st.integers(1, 40_000),
       float32=st.booleans(), diagnostics=st.booleans(), threads=st.integers(1, 3),
       seed=st.integers(0, 2**32 - 1))
def test_in_pass_and_separate_hashing_write_the_same_digests(n, n_m, chunk_rows, float32, diagnostics,
                                                             threads, seed):
    # Every kernel family sums in pass: rows of a few sensors (periodic), of one
    # or two vectors, of several vectors and of more than 64 sensors.
    n = min(n, 1_500_000 // n_m)
    values = np.random.default_rng(seed).normal(0.0, 1.0, (n, n_m))
    values = values.astype(np.float32) if float32 else values
    chunk_rows = max(chunk_rows, n // 100)  # short chunks, but not tens of thousands (the Rust tests cut to 1 row)
    tmp = Path(tempfile.mkdtemp(prefix="edmf-in-pass-"))
    before = _core.get_num_threads()
    try:
        _core.set_num_threads(threads)
        in_pass = _run(values, chunk_rows, diagnostics, tmp / "in_pass")
        Durable.in_pass = False
        try:
            separate = _run(values, chunk_rows, diagnostics, tmp / "separate")
        finally:
            Durable.in_pass = True
        a = state_file.read(tmp / "in_pass" / state_file.STATE)["rows"]
        b = state_file.read(tmp / "separate" / state_file.STATE)["rows"]
        assert a == b
        assert (a["blocks"], a["partial"]) == _separate(values)[:2]
        np.testing.assert_array_equal(in_pass.candidate_indices, separate.candidate_indices)
        # Each folder is a finished run the other hashing checks and accepts.
        Durable.in_pass = False
        try:
            again = _run(values, chunk_rows, diagnostics, tmp / "in_pass")
        finally:
            Durable.in_pass = True
        np.testing.assert_array_equal(again.candidate_indices, in_pass.candidate_indices)
        _run(values, chunk_rows, diagnostics, tmp / "separate")
    finally:
        _core.set_num_threads(before)
        shutil.rmtree(tmp, ignore_errors=True)


def test_a_run_hashed_in_pass_resumes_from_a_folder_hashed_separately(tmp_path, monkeypatch):
    values = np.random.default_rng(3).normal(0.0, 1.0, (2 * BLOCK + 500, 2))
    folder = tmp_path / "run"
    calls = []
    record = Durable.done

    def done_then_stop(self, first, rows):
        calls.append(first)
        if len(calls) == 3:
            raise KeyboardInterrupt
        record(self, first, rows)

    with monkeypatch.context() as m:  # the first session hashes separately and stops in its third chunk
        m.setattr(Durable, "in_pass", False)
        m.setattr(Durable, "done", done_then_stop)
        with pytest.raises(KeyboardInterrupt):
            _run(values, 3000, True, folder)
    assert state_file.read(folder / state_file.STATE)["n_done"] == 6000
    whole = _run(values, 3000, True, folder)  # resumed: skipped rows checked, the rest hashed in pass
    assert whole.n_instances == len(values)
    rows = state_file.read(folder / state_file.STATE)["rows"]
    assert (rows["blocks"], rows["partial"]) == _separate(values)[:2]
    changed = values.copy()
    changed[BLOCK + 7, 1] += 1.0
    with pytest.raises(ValueError, match="block 1"):
        _run(changed, 3000, True, folder)


def test_the_falsifier_feeds_a_digest_only_with_the_chunk():
    values = np.random.default_rng(4).normal(size=(3000, 2))
    acc = _core.Falsifier(np.zeros(2), np.full(2, -1.0), np.full(2, 1.0))
    d = _core.RowDigest()
    acc.update(values[:1111], digest=d)
    acc.update(np.asfortranarray(values[1111:]), digest=d)
    assert (d.blocks(), d.partial(), d.n_rows) == _separate(values)
    wide = _core.RowDigest()
    wide.update(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="columns"):
        acc.update(values[:10], digest=wide)
    assert acc.n_instances == 3000 and wide.n_rows == 4  # refused by both
    with pytest.raises(TypeError):
        acc.update(values[:10], digest="not a digest")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_a_checkpointed_run_reads_chunks_of_the_readers_size(tmp_path, monkeypatch, dtype):
    """A checkpoint cuts an array into the 16 MiB chunks the .npy reader reads,
    by the values' own size, and leaves a file's chunking to the reader: float32
    rows in chunks sized for float64 (half the bytes, twice the hand-overs) made
    checkpointed float32 streams up to 1.46 times as slow as unchecked ones."""
    from edmf_rs.engine import falsify as falsify_module
    from edmf_rs.stream import npy

    values = np.random.default_rng(5).normal(0.0, 1.0, (3000, 5)).astype(dtype)
    path = tmp_path / "p.npy"
    np.save(path, values)
    seen = []
    real_open = falsify_module.open_source

    def spy(predictions, n_sensors, chunk_rows=None):
        seen.append(chunk_rows)
        return real_open(predictions, n_sensors, chunk_rows)

    monkeypatch.setattr(falsify_module, "open_source", spy)
    t = Thresholds(np.full(5, -1.5), np.full(5, 1.5))
    edmf_rs.falsify(str(path), np.zeros(5), t, checkpoint=tmp_path / "file", progress=False)
    edmf_rs.falsify(values, np.zeros(5), t, checkpoint=tmp_path / "array", progress=False)
    assert seen == [None, npy.CHUNK_BYTES // (5 * np.dtype(dtype).itemsize)]
