"""A checkpoint folder changed since its run wrote it is refused, with a
message naming the file: part files carry sha256 checksums in the state and
are dtype-, shape- and range-checked; the state carries a checksum of its own
and its counts are range-checked; damage never surfaces as a raw exception."""

from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
from pathlib import Path

import edmf_rs
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from edmf_rs import Thresholds
from edmf_rs.stream import parts
from edmf_rs.stream import state as state_file

N_M = 4


def _case(n=3000, seed=0):
    rng = np.random.default_rng(seed)
    return rng.normal(0.0, 0.8, (n, N_M)), np.zeros(N_M), Thresholds(np.full(N_M, -1.5), np.full(N_M, 1.5))


def _finished(folder, seed=0, **kwargs):
    predictions, y, t = _case(seed=seed)
    result = edmf_rs.falsify(predictions, y, t, chunk_rows=1000, checkpoint=folder, checkpoint_every=0,
                             progress=False, **kwargs)
    return predictions, y, t, result


def _load(folder):
    return json.loads((folder / "state.json").read_text())


def _refused(folder, predictions, y, t, match, **kwargs):
    """Resuming from ``folder`` is refused with a ValueError matching ``match``."""
    with pytest.raises(ValueError, match=match):
        edmf_rs.falsify(predictions, y, t, chunk_rows=1000, checkpoint=folder, progress=False, **kwargs)


def _forge_part(folder, k, field, array):
    """Replaces a part and re-signs it in the state, as a careful forger would."""
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=False)
    (folder / f"part-{k:06d}.{field}.npy").write_bytes(buf.getvalue())
    state = _load(folder)
    state["parts"][k]["sha256"][field] = hashlib.sha256(buf.getvalue()).hexdigest()
    state_file.write(folder / "state.json", state)


def test_a_flipped_bit_in_a_part_is_refused(tmp_path):
    folder = tmp_path / "run"
    predictions, y, t, _ = _finished(folder)
    path = folder / "part-000001.candidates.npy"
    data = bytearray(path.read_bytes())
    data[-3] ^= 0x10
    path.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="part-000001.candidates.npy does not have the checksum"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder, progress=False)


def test_parts_copied_from_another_run_are_refused(tmp_path):
    predictions, y, t, _ = _finished(tmp_path / "a")
    _finished(tmp_path / "b", seed=1)
    for name in ("part-000000.candidates.npy", "part-000000.n_violated.npy"):
        shutil.copy(tmp_path / "b" / name, tmp_path / "a" / name)
    _refused(tmp_path / "a", predictions, y, t, "part-000000.candidates.npy does not have the checksum")


@pytest.mark.parametrize("array, match", [
    (np.array([-5, 3, 7], np.int64), "outside instances 1000..1999"),
    (np.array([1001.0, 1002.0]), "float64 array, expected 1-D int64"),
    (np.array([1005, 1003], np.int64), "not increasing"),
    (np.array([[1001]], np.int64), "2-D int64 array"),
])
def test_forged_candidate_indices_are_refused(tmp_path, array, match):
    folder = tmp_path / "run"
    predictions, y, t, _ = _finished(folder, keep_violations=False)
    state = _load(folder)
    state["parts"][1].update(n_candidates=len(array), candidates="indices")
    state_file.write(folder / "state.json", state)
    _forge_part(folder, 1, "candidates", array)
    _refused(folder, predictions, y, t, f"part-000001.candidates.npy .*{match}", keep_violations=False)


def _words(bits):
    """Little-endian uint64 words with the given bit positions set."""
    words = np.zeros(16, np.uint64)
    for b in bits:
        words[b // 64] |= np.uint64(1) << np.uint64(b % 64)
    return words


@pytest.mark.parametrize("array, n_candidates, match", [
    (_words([0, 999, 1000]), 3, "bits past its 1000 instances"),  # 1000 instances: bit 1000 is past them
    (_words([0, 5]), 3, "not 3 set"),
    (_words([0])[:15], 1, r"shape \(15,\), expected 16 rows"),
    (_words([0]).astype(np.int64), 1, "1-D int64 array, expected 1-D uint64"),
])
def test_forged_candidate_bitmaps_are_refused(tmp_path, array, n_candidates, match):
    folder = tmp_path / "run"
    predictions, y, t, _ = _finished(folder, keep_violations=False)
    assert _load(folder)["parts"][1]["candidates"] == "bitmap"  # dense candidates: the smaller form
    state = _load(folder)
    state["parts"][1]["n_candidates"] = n_candidates
    state_file.write(folder / "state.json", state)
    _forge_part(folder, 1, "candidates", array)
    _refused(folder, predictions, y, t, f"part-000001.candidates.npy .*{match}", keep_violations=False)


def test_an_unknown_candidate_form_is_refused(tmp_path):
    folder = tmp_path / "run"
    predictions, y, t, _ = _finished(folder)
    state = _load(folder)
    state["parts"][0]["candidates"] = "runs"
    state_file.write(folder / "state.json", state)
    with pytest.raises(ValueError, match=r"state.json gives part 0 candidates of form 'runs', expected one of "
                                         r"\['bitmap', 'indices'\]"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder, progress=False)


def test_forged_violation_counts_are_refused(tmp_path):
    folder = tmp_path / "run"
    predictions, y, t, result = _finished(folder)
    counts = np.asarray(result.n_violated[:1000]).copy()
    for bad in (np.where(counts == 0, 0, N_M + 1), np.where(counts == 0, 1, counts)):
        _forge_part(folder, 0, "n_violated", bad.astype(np.int32))
        _refused(folder, predictions, y, t, "part-000000.n_violated.npy holds counts of violated sensors")
    _forge_part(folder, 0, "n_violated", counts.astype(np.int64))
    _refused(folder, predictions, y, t, "part-000000.n_violated.npy holds a 1-D int64 array, expected 1-D int32")


def test_hand_edited_tallies_are_refused(tmp_path):
    folder = tmp_path / "run"
    predictions, y, t, _ = _finished(folder)
    state = _load(folder)
    state["tally"]["per_sensor_falsified"][0] += 1
    (folder / "state.json").write_text(json.dumps(state))  # checksum left as it was
    _refused(folder, predictions, y, t, "state.json is not an edmf_rs checkpoint state .*checksum")
    state["tally"]["per_sensor_falsified"][0] = state["n_done"] + 1  # re-signed, but impossible
    state_file.write(folder / "state.json", state)
    _refused(folder, predictions, y, t, "state.json is not an edmf_rs checkpoint state .*range")


@pytest.mark.parametrize("text, why", [
    ("[" * 100_000 + "]" * 100_000, "RecursionError"),
    ('{"format": "%s", "n_done": 1' % state_file.FORMAT + "0" * 400 + "}", ""),
    ('{"format": "%s", "n_done": 1e400}' % state_file.FORMAT, ""),
    ('{"format": "%s", "n_done": NaN}' % state_file.FORMAT, "NaN"),
    (b"\xff\xfe{}", ""),
])
def test_a_damaged_state_is_a_clean_error_naming_the_file(tmp_path, text, why):
    predictions, y, t = _case(100)
    folder = tmp_path / "run"
    folder.mkdir()
    path = folder / "state.json"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(ValueError, match=f"{path}.* is not an edmf_rs checkpoint state .*{why}"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder, progress=False)


def test_a_forged_huge_count_is_a_clean_error(tmp_path):
    # Signed by hand (state_file.write refuses nothing, but NumPy would overflow on reading it).
    folder = tmp_path / "run"
    predictions, y, t, _ = _finished(folder)
    state = _load(folder)
    state["tally"]["n_invalid"] = 2**70
    body = {k: v for k, v in state.items() if k != "checksum"}
    canonical = json.dumps(body, sort_keys=True, separators=(",", ":")).encode()
    state["checksum"] = hashlib.sha256(canonical).hexdigest()
    (folder / "state.json").write_text(json.dumps(state))
    _refused(folder, predictions, y, t, "state.json is not an edmf_rs checkpoint state .*int64")


def test_a_fifo_in_place_of_a_file_is_refused_not_waited_on(tmp_path):
    predictions, y, t = _case(100)
    os.mkfifo(tmp_path / "p.npy")
    with pytest.raises(ValueError, match="p.npy is not a regular file"):
        edmf_rs.falsify(tmp_path / "p.npy", y, t, progress=False)
    folder = tmp_path / "run"
    folder.mkdir()
    os.mkfifo(folder / "state.json")
    with pytest.raises(ValueError, match="state.json is not an edmf_rs checkpoint state .*not a regular file"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder, progress=False)


def test_forged_violation_counts_beside_candidate_indices_are_refused(tmp_path):
    folder = tmp_path / "run"
    predictions, y, _ = _case()
    t = Thresholds(np.full(N_M, -0.3), np.full(N_M, 0.3))  # few candidates: parts store indices
    result = edmf_rs.falsify(predictions, y, t, chunk_rows=1000, checkpoint=folder, checkpoint_every=0,
                             progress=False)
    assert _load(folder)["parts"][0]["candidates"] == "indices" and result.n_candidates > 0
    counts = np.asarray(result.n_violated[:1000]).copy()
    counts[result.candidate_indices[0]] = 1  # a candidate with a violated sensor
    _forge_part(folder, 0, "n_violated", counts.astype(np.int32))
    _refused(folder, predictions, y, t, "part-000000.n_violated.npy holds counts of violated sensors")


@pytest.mark.parametrize("numpy_counts_bits", [True, False])
@given(words=st.lists(st.integers(0, 2**64 - 1), min_size=1, max_size=40), n_past=st.integers(0, 63))
@settings(max_examples=60, deadline=None)
def test_a_bitmap_check_without_unpacking_agrees_with_the_unpacked_bits(numpy_counts_bits, words, n_past):
    # check_bitmap counts bits with np.bitwise_count where NumPy has it (2.0 on), else by unpacking
    words = np.array(words, dtype="<u8")
    n_instances = max(len(words) * 64 - n_past, (len(words) - 1) * 64 + 1)
    bits = np.unpackbits(words.view(np.uint8), bitorder="little").astype(bool)
    past, count = bits[n_instances:].any(), int(bits.sum())
    with pytest.MonkeyPatch.context() as mp:
        if not numpy_counts_bits and hasattr(np, "bitwise_count"):
            mp.delattr(np, "bitwise_count")
        for n_candidates in (count, count + 1):
            good = not past and n_candidates == count
            try:
                parts.check_bitmap(Path("p.npy"), words, n_instances, n_candidates)
                refused = False
            except ValueError:
                refused = True
            assert refused != good
    np.testing.assert_array_equal(parts.bitmap_mask(words, n_instances), bits[:n_instances])
