"""Periodic checkpoint saves take at most ``checkpoint.MAX_SAVE_SHARE`` (5 %)
of a run's time: a save waits until the run has worked 19 times as long as
the last save took, even with ``checkpoint_every=0``.

Was: ``checkpoint_every=0`` saved after every chunk, and each save rewrites
the state, which lists every part so far, so N tiny chunks cost O(N^2):
2e6 instances in chunks of 1000 took 60 s (2001 saves, the last ones 44 ms
each), against 0.14 s with a save a minute. Time here is a fake clock: a
chunk and a save take what each case says."""

from __future__ import annotations

import types

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds
from edmf_rs.stream import checkpoint

#: The default (tests/conftest.py lifts it for the other tests, which count saves).
DEFAULT_SHARE = checkpoint.MAX_SAVE_SHARE
N_M, ROWS = 3, 10
SAVE = 0.1  # seconds a state write takes on the fake clock


def _case(n_chunks):
    predictions = np.random.default_rng(21).normal(0.0, 1.0, (n_chunks * ROWS, N_M))
    return predictions, np.zeros(N_M), Thresholds(np.full(N_M, -1.2), np.full(N_M, 1.2))


def _candidates(predictions, y, thresholds):
    residual = predictions - y
    return np.flatnonzero(np.all((residual >= thresholds.low) & (residual <= thresholds.high), axis=1))


@pytest.fixture
def clock(monkeypatch):
    """A fake clock for the checkpoint, and the states written: (time after the write, n_done)."""
    now, saves = [0.0], []
    original = checkpoint.save_state

    def slow_save(path, state):
        now[0] += SAVE
        saves.append((now[0], state["n_done"]))
        return original(path, state)

    monkeypatch.setattr(checkpoint, "MAX_SAVE_SHARE", DEFAULT_SHARE)
    monkeypatch.setattr(checkpoint, "time", types.SimpleNamespace(monotonic=lambda: now[0]))
    monkeypatch.setattr(checkpoint, "save_state", slow_save)
    return now, saves


def _chunks(predictions, now, seconds, stop_at=None):
    for k in range(0, len(predictions), ROWS):
        if k // ROWS == stop_at:
            raise KeyboardInterrupt
        now[0] += seconds
        yield predictions[k:k + ROWS]


def test_the_default_share_is_the_documented_five_percent():
    assert DEFAULT_SHARE == 0.05


def test_saves_after_chunks_faster_than_a_save_take_at_most_five_percent(tmp_path, clock):
    now, saves = clock
    n_chunks, chunk = 2000, 0.01  # 10 chunks per save's time
    predictions, y, thresholds = _case(n_chunks)
    result = edmf_rs.falsify(_chunks(predictions, now, chunk), y, thresholds, checkpoint=tmp_path / "run",
                             checkpoint_every=0, progress=False)
    np.testing.assert_array_equal(result.candidate_indices, _candidates(predictions, y, thresholds))
    periodic = saves[1:-1]  # not the first save's claim (saves[0], n_done 0) nor the final state
    assert saves[0][1] == 0 and saves[-1][1] == len(predictions)
    assert len(periodic) < 20, len(periodic)  # not 2000
    # after a save (of SAVE seconds; the first, with its claim, 2 * SAVE) the next waits 19 times as long
    waited = np.diff([n for _, n in periodic]) / ROWS * chunk
    assert np.all(waited >= 19 * SAVE - 1e-9)
    assert len(periodic) * SAVE <= 0.05 * now[0] + 2 * SAVE


def test_chunks_slower_than_19_saves_are_each_saved(tmp_path, clock):
    now, saves = clock
    predictions, y, thresholds = _case(30)
    # 19 times the first save (its claim and its state: 2 * SAVE) is 3.8 s
    result = edmf_rs.falsify(_chunks(predictions, now, 40 * SAVE), y, thresholds, checkpoint=tmp_path / "run",
                             checkpoint_every=0, progress=False)
    np.testing.assert_array_equal(result.candidate_indices, _candidates(predictions, y, thresholds))
    assert [n for _, n in saves[1:]] == list(range(ROWS, 31 * ROWS, ROWS)) + [30 * ROWS]  # every chunk, then final


def test_ctrl_c_saves_at_once_and_the_run_resumes_exactly(tmp_path, clock):
    now, saves = clock
    predictions, y, thresholds = _case(2000)
    folder = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        edmf_rs.falsify(_chunks(predictions, now, 0.01, stop_at=1234), y, thresholds, checkpoint=folder,
                        checkpoint_every=0, progress=False)
    assert saves[-1][1] == 1234 * ROWS  # an interruption saves the work done, however soon after a save
    result = edmf_rs.falsify(_chunks(predictions, now, 0.01), y, thresholds, checkpoint=folder,
                             checkpoint_every=0, progress=False)
    np.testing.assert_array_equal(result.candidate_indices, _candidates(predictions, y, thresholds))
    assert result.n_instances == len(predictions)
