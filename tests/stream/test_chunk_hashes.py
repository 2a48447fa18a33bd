"""Resumes that check every row: a checkpoint records a digest of every block
of instances it has done, and a resume or a finished folder re-reads and
re-checks them all (not only the first and last rows)."""

from __future__ import annotations

import json

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds, _core
from hypothesis import given, settings
from hypothesis import strategies as st

N_M = 3
BLOCK = _core.RowDigest.block_rows


def _case(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.normal(0.0, 1.0, (n, N_M)), np.zeros(N_M), Thresholds(np.full(N_M, -1.5), np.full(N_M, 1.5))


def _digests(arr, step):
    d = _core.RowDigest()
    for i in range(0, len(arr), step):
        d.update(arr[i:i + step])
    return d.blocks(), d.partial(), d.n_rows


@settings(max_examples=25, deadline=None)
@given(n=st.integers(0, 3 * 1024 + 7), cols=st.integers(1, 5), step=st.integers(1, 2000),
       seed=st.integers(0, 2**32 - 1))
def test_the_digest_depends_on_the_values_only(n, cols, step, seed):
    values = np.random.default_rng(seed).normal(size=(n, cols)).astype(np.float32)
    want = _digests(values, max(n, 1))
    assert _digests(values, step) == want  # any chunking
    assert _digests(np.asfortranarray(values), step) == want  # any layout
    wide = np.zeros((n, 2 * cols), np.float32)
    wide[:, ::2] = values
    assert _digests(wide[:, ::2], step) == want  # strided
    as_f64 = values.astype(np.float64)
    assert _digests(np.asfortranarray(as_f64), step) == _digests(as_f64, max(n, 1))
    if n:
        assert _digests(as_f64, step) != want  # float32 values stored as float64: another input
        changed = values.copy()
        changed[seed % n, seed % cols] = np.nextafter(changed[seed % n, seed % cols], np.float32(np.inf))
        assert _digests(changed, step) != want  # one ulp anywhere


def test_blocks_split_at_fixed_instances():
    values = np.random.default_rng(1).normal(size=(2 * BLOCK + 10, 2))
    blocks, partial, n = _digests(values, 5000)
    assert len(blocks) == 2 and partial is not None and n == len(values)
    changed = values.copy()
    changed[BLOCK + 3, 1] += 1.0
    after, partial_after, _ = _digests(changed, 7777)
    assert after[0] == blocks[0] and after[1] != blocks[1] and partial_after == partial
    with pytest.raises(ValueError, match="columns"):
        d = _core.RowDigest()
        d.update(values[:3])
        d.update(np.zeros((3, 5)))


def test_a_finished_checkpoint_over_a_npy_with_changed_interior_rows_is_refused(tmp_path):
    # The fault: only the first and last rows were checked, so a file whose
    # interior changed returned the old answer (candidates where there are none).
    n = 3 * BLOCK
    predictions, y, t = _case(n)
    predictions[:] = np.clip(predictions, -1.0, 1.0)  # every instance a candidate
    path = tmp_path / "p.npy"
    np.save(path, predictions)
    folder = tmp_path / "run"
    before = edmf_rs.falsify(path, y, t, checkpoint=folder, progress=False)
    assert len(before.candidate_indices) == n
    changed = predictions.copy()
    changed[1:-1, 0] = 5.0  # every interior instance now falsified
    np.save(path, changed)
    assert len(edmf_rs.falsify(path, y, t, progress=False).candidate_indices) == 2
    with pytest.raises(ValueError, match=r"differ from the run saved .* in instances 0\.\.65535 \(block 0"):
        edmf_rs.falsify(path, y, t, checkpoint=folder, progress=False)
    changed = predictions.copy()
    changed[2 * BLOCK + 5, 2] += 1e-12
    np.save(path, changed)
    with pytest.raises(ValueError, match=r"instances 131072\.\.196607 \(block 2"):
        edmf_rs.falsify(path, y, t, checkpoint=folder, progress=False, chunk_rows=1000)
    np.save(path, predictions)
    got = edmf_rs.falsify(path, y, t, checkpoint=folder, progress=False)
    np.testing.assert_array_equal(got.candidate_indices, before.candidate_indices)


def test_a_resume_checks_every_row_done_with_any_chunking(tmp_path):
    n = BLOCK + 5000
    predictions, y, t = _case(n, seed=3)
    chunks = [predictions[i:i + 999] for i in range(0, n, 999)]

    def stop_after(k):
        for i, c in enumerate(chunks):
            if i == k:
                raise KeyboardInterrupt
            yield c

    folder = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        edmf_rs.falsify(stop_after(70), y, t, checkpoint=folder, checkpoint_every=3600, progress=False)
    state = json.loads((folder / "state.json").read_text())
    assert state["n_done"] == 70 * 999 and len(state["rows"]["blocks"]) == 1
    def pieces(arr):  # another chunking than the interrupted run's
        return [arr[i:i + 4096] for i in range(0, n, 4096)]

    changed = predictions.copy()
    changed[40_000, 1] = -changed[40_000, 1] + 0.5
    with pytest.raises(ValueError, match=r"instances 0\.\.65535 \(block 0"):
        edmf_rs.falsify(pieces(changed), y, t, checkpoint=folder, progress=False)
    changed = predictions.copy()
    changed[69_000, 0] += 1.0  # in the partial block, before the position reached
    with pytest.raises(ValueError, match=r"instances 65536\.\.69929 \(block 1"):
        edmf_rs.falsify(pieces(changed), y, t, checkpoint=folder, progress=False)
    # The same values in another byte order, layout and chunking resume.
    got = edmf_rs.falsify(pieces(np.asfortranarray(predictions.astype(">f8"))), y, t, checkpoint=folder,
                          progress=False)
    want = edmf_rs.falsify(predictions, y, t, progress=False)
    np.testing.assert_array_equal(got.candidate_indices, want.candidate_indices)
    np.testing.assert_array_equal(got.per_sensor_falsified, want.per_sensor_falsified)


def test_a_finished_run_folder_holds_what_the_docs_say(tmp_path):
    # README "Resumable runs": state.json, .lock and the listed part files, nothing else.
    predictions, y, t = _case(5000)
    folder = tmp_path / "run"
    edmf_rs.falsify(predictions, y, t, chunk_rows=1000, checkpoint=folder, checkpoint_every=0, progress=False)
    state = json.loads((folder / "state.json").read_text())
    names = {f"part-{k:06d}.{field}.npy" for k in range(len(state["parts"])) for field in ("candidates", "n_violated")}
    assert len(state["parts"]) == 5
    assert {p.name for p in folder.iterdir()} == {"state.json", ".lock"} | names
    theta = np.random.default_rng(0).uniform(size=(300, 2))
    model = edmf_rs.falsify_model(lambda p: np.repeat(p[:, :1], N_M, axis=1), theta, y, t, batch_size=100,
                                  checkpoint=tmp_path / "model", checkpoint_every=0, progress=False)
    assert model.n_instances == 300
    state = json.loads((tmp_path / "model" / "state.json").read_text())
    names = {f"part-{k:06d}.{field}.npy" for k in range(3) for field in ("candidates", "parameters", "predictions")}
    assert {p.name for p in (tmp_path / "model").iterdir()} == {"state.json", ".lock"} | names
    assert state["rereadable"] is True and state["complete"] is True
