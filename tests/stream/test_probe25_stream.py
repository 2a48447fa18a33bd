"""Session 25's probe of streaming and the Dask path (regressions): bad
arguments are refused naming the argument, before any work, and a
checkpoint folder's files that no run wrote are never overwritten or removed."""

from __future__ import annotations

import dask.array as da
import edmf_rs
import edmf_rs.dask as edask
import numpy as np
import pytest
from edmf_rs import Thresholds
from edmf_rs.stream.checkpoint import CheckpointError

N_M = 3


def _case(n=600):
    predictions = np.random.default_rng(4).normal(0.0, 1.0, (n, N_M))
    return predictions, np.zeros(N_M), Thresholds(np.full(N_M, -1.2), np.full(N_M, 1.2))


def _model(theta):
    return np.column_stack([theta[:, 0], theta[:, 1], theta[:, 0] - theta[:, 1]])


@pytest.mark.parametrize("client", ["tcp://scheduler:8786", object(), 4])
def test_dask_falsify_refuses_a_client_that_is_not_one(client):
    # was: AttributeError: 'str' object has no attribute 'compute', from deep inside
    predictions, y, thresholds = _case()
    with pytest.raises(TypeError, match=r"client: expected a distributed\.Client.*got (str|object|int)"):
        edask.falsify(da.from_array(predictions, chunks=(100, -1)), y, thresholds, client=client, progress=False)


def test_dask_falsify_refuses_a_path_or_ragged_blocks_by_name(tmp_path):
    # was: "got shape ()" for a path, and NumPy's own inhomogeneous-shape error for ragged blocks
    predictions, y, thresholds = _case()
    np.save(tmp_path / "p.npy", predictions)
    with pytest.raises(TypeError, match=r"predictions: expected a dask array .* got a path; stream a \.npy file"):
        edask.falsify(str(tmp_path / "p.npy"), y, thresholds, progress=False)
    with pytest.raises(TypeError, match=r"predictions: expected a 2-D array of numbers"):
        edask.falsify([predictions[:10], predictions[10:]], y, thresholds, progress=False)
    with pytest.raises(TypeError, match=r"predictions: expected a dask array .* got generator"):
        edask.falsify((block for block in [predictions]), y, thresholds, progress=False)


def test_dask_falsify_model_refuses_a_bad_client_before_drawing_batches():
    _, y, thresholds = _case()
    drawn = []

    def batches():
        for k in range(3):
            drawn.append(k)
            yield np.full((5, 2), float(k))

    with pytest.raises(TypeError, match=r"client: expected a distributed\.Client"):
        edask.falsify_model(_model, batches(), y, thresholds, client="tcp://scheduler:8786", window=2,
                            progress=False)
    assert drawn == []


def test_dask_falsify_model_refuses_parameters_of_unknown_chunk_sizes():
    # was: Dask's own "Array chunk sizes are unknown" from a rechunk, naming no argument
    _, y, thresholds = _case()
    theta = np.random.default_rng(5).normal(0.0, 1.0, (500, 2))
    keep = da.from_array(theta[:, 0] > -0.5, chunks=100)
    unknown = da.from_array(theta, chunks=(100, -1))[keep]
    with pytest.raises(ValueError, match=r"parameters: expected a dask array of known chunk sizes.*compute_chunk_sizes"):
        edask.falsify_model(_model, unknown, y, thresholds, batch_size=64, progress=False)
    # the advice works, and gives the NumPy rule's answer
    known = unknown.compute_chunk_sizes()
    result = edask.falsify_model(_model, known, y, thresholds, batch_size=64, progress=False)
    kept = theta[theta[:, 0] > -0.5]
    residual = _model(kept) - y
    expected = np.flatnonzero(np.all((residual >= -1.2) & (residual <= 1.2), axis=1))
    np.testing.assert_array_equal(result.candidate_indices, expected)
    np.testing.assert_array_equal(result.candidate_parameters, kept[expected])


# -- files named like parts that no run wrote --------------------------------

CHUNK = 100


def _candidates(predictions, y, thresholds):
    residual = np.asarray(predictions, np.float64) - y
    return np.flatnonzero(np.all((residual >= thresholds.low) & (residual <= thresholds.high), axis=1))


def _interrupted(folder, predictions, y, thresholds, after):
    def chunks():
        for k in range(0, len(predictions), CHUNK):
            if k == after * CHUNK:
                raise KeyboardInterrupt
            yield predictions[k:k + CHUNK]

    with pytest.raises(KeyboardInterrupt):
        edmf_rs.falsify(chunks(), y, thresholds, checkpoint=folder, checkpoint_every=0, progress=False)


def test_a_users_file_named_like_the_first_part_is_refused_not_overwritten(tmp_path):
    # was: silently overwritten by the run's first save
    predictions, y, thresholds = _case()
    folder = tmp_path / "run"
    folder.mkdir()
    mine = folder / "part-000000.candidates.npy"
    mine.write_bytes(b"the user's own data")
    with pytest.raises(ValueError, match=r"holds part-000000\.candidates\.npy, which is no part of the run"):
        edmf_rs.falsify(predictions, y, thresholds, checkpoint=folder, progress=False)
    assert mine.read_bytes() == b"the user's own data"


def test_a_foreign_part_reached_mid_run_stops_the_run_and_is_kept(tmp_path):
    # was: overwritten by the resumed run's second save
    predictions, y, thresholds = _case()
    folder = tmp_path / "run"
    _interrupted(folder, predictions, y, thresholds, after=2)
    mine = folder / "part-000003.candidates.npy"  # the resumed run's second save
    mine.write_bytes(b"another run's file")
    chunks = [predictions[k:k + CHUNK] for k in range(0, len(predictions), CHUNK)]
    with pytest.raises(CheckpointError, match=r"holds part-000003\.candidates\.npy.*move it away"):
        edmf_rs.falsify(chunks, y, thresholds, checkpoint=folder, checkpoint_every=0, progress=False)
    assert mine.read_bytes() == b"another run's file"
    mine.rename(tmp_path / "moved.npy")
    result = edmf_rs.falsify(chunks, y, thresholds, checkpoint=folder, checkpoint_every=0, progress=False)
    np.testing.assert_array_equal(result.candidate_indices, _candidates(predictions, y, thresholds))


def test_finishing_keeps_a_foreign_file_at_the_next_parts_name(tmp_path):
    # was: removed at the end as if a crash had left it
    predictions, y, thresholds = _case()
    folder = tmp_path / "run"
    folder.mkdir()
    mine = folder / "part-000001.candidates.npy"  # the name the state lists as the next save's
    mine.write_bytes(b"the user's own data")
    result = edmf_rs.falsify(predictions, y, thresholds, checkpoint=folder, progress=False)
    np.testing.assert_array_equal(result.candidate_indices, _candidates(predictions, y, thresholds))
    assert mine.read_bytes() == b"the user's own data"


def test_a_first_save_left_without_any_state_is_refused_not_overwritten(tmp_path):
    # A crash during the first save leaves the state claiming its parts (tests/stream/test_first_save.py),
    # so first parts with no state beside them are no run's that a run may overwrite: the .lock is no sign
    # (was: redone, and so a user's file at such a name overwritten).
    predictions, y, thresholds = _case()
    folder = tmp_path / "run"
    _interrupted(folder, predictions, y, thresholds, after=1)
    (folder / "state.json").unlink()
    left = folder / "part-000000.candidates.npy"
    kept = left.read_bytes()
    assert (folder / ".lock").exists()
    with pytest.raises(ValueError, match=r"holds part-000000\.candidates\.npy, which is no part of the run"):
        edmf_rs.falsify(predictions, y, thresholds, checkpoint=folder, progress=False)
    assert left.read_bytes() == kept and not (folder / "state.json").exists()
