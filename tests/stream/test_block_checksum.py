"""The checkpoint's block checksum (``fletcher64x8/2``, rust/src/digest.rs)
against its NumPy reference (``edmf_rs.reference.row_checksums``), whatever
the byte order, layout, chunking and thread count, for float64 and float32; the accidental
changes it must catch; and the refusal of checkpoints of the earlier format."""

from __future__ import annotations

import json

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds, _core, reference
from edmf_rs.stream import state as state_file
from edmf_rs.stream.checkpoint import digestible
from hypothesis import given, settings
from hypothesis import strategies as st

BLOCK = _core.RowDigest.block_rows
SPECIAL = np.array([0.0, -0.0, np.nan, -np.inf, np.inf, 5e-324, -1.0, 1.0, 2.0, 1e308])


def _values(seed, n, cols, dtype, special):
    rng = np.random.default_rng(seed)
    values = rng.normal(0.0, 10.0, (n, cols))
    if special and values.size:
        mask = rng.random(values.shape) < 0.2
        values[mask] = rng.choice(SPECIAL, mask.sum())
    return values.astype(dtype)


def _layout(values, how):
    if how == "F":
        return np.asfortranarray(values)
    if how == "strided":
        wide = np.zeros((values.shape[0], 2 * values.shape[1]), values.dtype)
        wide[:, 1::2] = values
        return wide[:, 1::2]
    if how == "reversed-rows":  # negative strides: handed over as a copy
        return np.ascontiguousarray(values[::-1])[::-1]
    return values


def _rust(values, cuts):
    d = _core.RowDigest()
    start = 0
    for stop in cuts + [len(values)]:
        d.update(digestible(values[start:stop]))  # as a checkpoint hands rows over
        start = stop
    return reference.RowChecksums(tuple(d.blocks()), d.partial(), d.n_rows)


@settings(max_examples=30, deadline=None)
@given(n=st.one_of(st.integers(0, 3000), st.integers(BLOCK - 5, BLOCK + 2000)), cols=st.integers(1, 12),
       dtype=st.sampled_from(["<f8", "<f4", ">f8", ">f4"]), layout=st.sampled_from(["C", "F", "strided",
       "reversed-rows"]), special=st.booleans(), threads=st.integers(1, 3), seed=st.integers(0, 2**32 - 1),
       data=st.data())
def test_rust_gives_the_checksums_of_the_reference(n, cols, dtype, layout, special, threads, seed, data):
    values = _values(seed, n, cols, dtype, special)
    cuts = sorted(data.draw(st.lists(st.integers(0, n), max_size=4)))
    want = reference.row_checksums(values)
    assert want == reference.row_checksums(values.astype(values.dtype.newbyteorder("S")))  # not the byte order
    if values.dtype.itemsize == 4 and n:  # the same values as float64 are another input
        assert reference.row_checksums(values.astype(np.float64)) != want
    before = _core.get_num_threads()
    try:
        _core.set_num_threads(threads)
        assert _rust(_layout(values, layout), cuts) == want
        # In the falsifier's own pass (screening or diagnostics), chunk by chunk.
        thresholds = Thresholds(np.full(cols, -5.0), np.full(cols, 5.0))
        acc = _core.Falsifier(np.zeros(cols), thresholds.low, thresholds.high, diagnostics=bool(seed % 2),
                              keep_violations=False)
        d = _core.RowDigest()
        arr = _layout(values, layout)
        if arr.dtype.byteorder == ">" or arr.strides[0] < 0:
            arr = np.ascontiguousarray(arr, dtype=arr.dtype.newbyteorder("="))
        start = 0
        for stop in cuts + [n]:
            acc.update(arr[start:stop], digest=d)
            start = stop
        assert reference.RowChecksums(tuple(d.blocks()), d.partial(), d.n_rows) == want
    finally:
        _core.set_num_threads(before)


def _case(n, cols=5, seed=0):
    rng = np.random.default_rng(seed)
    predictions = np.clip(rng.normal(0.0, 1.0, (n, cols)), -1.0, 1.0)  # every instance a candidate
    return predictions, np.zeros(cols), Thresholds(np.full(cols, -1.5), np.full(cols, 1.5))


def _finished(tmp_path, predictions, y, t):
    path = tmp_path / "p.npy"
    np.save(path, predictions)
    folder = tmp_path / "run"
    edmf_rs.falsify(path, y, t, checkpoint=folder, progress=False)
    return path, folder


@pytest.mark.parametrize("change", ["rows", "columns", "bit", "sign"])
def test_a_finished_checkpoint_refuses_swapped_rows_columns_and_flipped_bits(tmp_path, change):
    n = 2 * BLOCK + 100
    predictions, y, t = _case(n)
    path, folder = _finished(tmp_path, predictions, y, t)
    changed = predictions.copy()
    if change == "rows":
        changed[[BLOCK + 7, BLOCK + 9000]] = changed[[BLOCK + 9000, BLOCK + 7]]
    elif change == "columns":
        changed[:, [1, 3]] = changed[:, [3, 1]]
    elif change == "bit":
        changed.view(np.uint64)[BLOCK + 123, 2] ^= np.uint64(1 << 17)
    else:  # two signs in one column, a power-of-two number of steps apart
        changed[BLOCK + 8, 0] *= -1.0
        changed[BLOCK + 24, 0] *= -1.0  # same lane, 10 steps apart: plain 64-bit sums miss it
    assert not np.array_equal(changed, predictions)
    np.save(path, changed)
    block = 0 if change == "columns" else 1
    first, last = block * BLOCK, (block + 1) * BLOCK - 1
    with pytest.raises(ValueError, match=rf"in instances {first}\.\.{last} \(block {block}, the first"):
        edmf_rs.falsify(path, y, t, checkpoint=folder, progress=False)
    np.save(path, predictions)  # the original input: the saved result
    assert edmf_rs.falsify(path, y, t, checkpoint=folder, progress=False).n_instances == n


def test_a_checkpoint_of_the_earlier_format_is_refused_with_a_clear_message(tmp_path):
    predictions, y, t = _case(3000)
    path, folder = _finished(tmp_path, predictions, y, t)
    state = json.loads((folder / "state.json").read_text())
    state["format"] = "edmf_rs.checkpoint/2"  # what the xxh3 version wrote, re-signed
    state["rows"].pop("checksum")
    state_file.write(folder / "state.json", state)
    with pytest.raises(ValueError, match=r"earlier version of edmf_rs \(format 'edmf_rs.checkpoint/2', with xxh3 "
                                         r"digests of its rows\).*delete the folder or pass another one"):
        edmf_rs.falsify(path, y, t, checkpoint=folder, progress=False)
    # A current-format state that names another checksum is refused too.
    state["format"] = state_file.FORMAT
    for other in ("xxh3-128/1", "fletcher64x8/1"):  # version 1 widened float32 to float64
        state["rows"]["checksum"] = other
        state_file.write(folder / "state.json", state)
        with pytest.raises(ValueError, match=rf"checksums '{other}' of 65536-instance blocks, this version uses "
                                             r"'fletcher64x8/2'"):
            edmf_rs.falsify(path, y, t, checkpoint=folder, progress=False)
