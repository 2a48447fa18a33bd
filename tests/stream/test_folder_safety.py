"""A checkpoint folder's lock is never followed through a symbolic link nor
waited on as a FIFO; the run's clean-up keeps files it did not write."""

from __future__ import annotations

import os
import warnings

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds

N_M = 2


def _case(n=500):
    rng = np.random.default_rng(0)
    return rng.normal(size=(n, N_M)), np.zeros(N_M), Thresholds(np.full(N_M, -1.0), np.full(N_M, 1.0))


def test_a_lock_symlink_is_not_followed(tmp_path):
    predictions, y, t = _case()
    folder = tmp_path / "run"
    folder.mkdir()
    victim = tmp_path / "precious.txt"
    victim.write_text("keep me")
    (folder / ".lock").symlink_to(victim)
    with pytest.raises(ValueError, match=r"\.lock is a symbolic link, which a run does not follow"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder, progress=False)
    (folder / ".lock").unlink()
    (folder / ".lock").symlink_to(tmp_path / "nowhere")  # dangling: would be created by following it
    with pytest.raises(ValueError, match="symbolic link"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder, progress=False)
    assert victim.read_text() == "keep me" and not (tmp_path / "nowhere").exists()
    assert not (folder / "state.json").exists()


def test_a_lock_that_is_a_fifo_is_refused_not_waited_on(tmp_path):
    predictions, y, t = _case()
    folder = tmp_path / "run"
    folder.mkdir()
    os.mkfifo(folder / ".lock")
    with pytest.raises(ValueError, match=r"\.lock is not a regular file"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder, progress=False)


def test_a_lock_that_is_a_directory_is_refused_not_run_unlocked(tmp_path):
    predictions, y, t = _case()
    folder = tmp_path / "run"
    (folder / ".lock").mkdir(parents=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # formerly a warning, and the run went on unlocked
        with pytest.raises(ValueError, match=r"run/\.lock is not a regular file"):
            edmf_rs.falsify(predictions, y, t, checkpoint=folder, progress=False)
    assert not (folder / "state.json").exists()


def test_a_device_as_predictions_is_refused(tmp_path):
    _, y, t = _case()
    with pytest.raises(ValueError, match="/dev/zero is not a regular file"):
        edmf_rs.falsify("/dev/zero", y, t, progress=False)
