"""A checkpoint folder removed, emptied or replaced while a run saves into it
stops the run at its next save, naming the folder. Before, the saves
recreated the folder and the run failed only when it read the parts back at
the end, after all the work, because the first parts were gone."""

from __future__ import annotations

import os
import shutil

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds
from edmf_rs.stream.checkpoint import CheckpointError

N_M, ROWS, CHUNKS, AT = 3, 200, 8, 3


def _remove(folder):
    shutil.rmtree(folder)


def _empty(folder):
    for path in folder.iterdir():
        path.unlink()


def _replace(folder):
    shutil.rmtree(folder)
    folder.mkdir()


@pytest.mark.parametrize("change", [_remove, _empty, _replace])
def test_a_folder_changed_under_a_run_stops_it_at_the_next_save(tmp_path, change):
    folder = tmp_path / "run"
    rng = np.random.default_rng(7)
    drawn = []

    def chunks():
        for k in range(CHUNKS):
            if k == AT:  # three chunks done and saved (checkpoint_every=0 saves after each)
                assert (folder / "state.json").is_file()
                change(folder)
            drawn.append(k)
            yield rng.normal(0.0, 1.0, (ROWS, N_M))

    t = Thresholds(np.full(N_M, -1.5), np.full(N_M, 1.5))
    with pytest.raises(CheckpointError, match=rf"checkpoint: folder {folder} was removed, emptied or changed during the "
                                              rf"run, which had saved {AT * ROWS} instances there"):
        edmf_rs.falsify(chunks(), np.zeros(N_M), t, checkpoint=folder, checkpoint_every=0, progress=False,
                        trust_iterable=True)
    assert drawn == list(range(AT + 1))  # stopped at the save after the change, not at the end
    assert not (folder / "state.json").exists()  # no state recreated that would miss the first parts


def test_a_folder_restored_from_an_older_copy_stops_the_run_at_the_next_save(tmp_path):
    # the state and parts of save 1 put back after save 3: the run would go on and fail only at the end
    folder, copy = tmp_path / "run", tmp_path / "copy"
    rng = np.random.default_rng(8)

    def chunks():
        for k in range(CHUNKS):
            if k == 1:
                shutil.copytree(folder, copy)  # after the first save
            if k == AT:
                shutil.rmtree(folder)
                shutil.copytree(copy, folder)  # copy2: the old files keep their times
            yield rng.normal(0.0, 1.0, (ROWS, N_M))

    t = Thresholds(np.full(N_M, -1.5), np.full(N_M, 1.5))
    with pytest.raises(CheckpointError, match="was removed, emptied or changed during the run"):
        edmf_rs.falsify(chunks(), np.zeros(N_M), t, checkpoint=folder, checkpoint_every=0, progress=False,
                        trust_iterable=True)


def test_a_relative_folder_stays_where_it_was_when_the_model_changes_directory(tmp_path, monkeypatch):
    # solver wrappers often chdir into a work folder; the checkpoint must not follow them
    start, elsewhere = tmp_path / "start", tmp_path / "elsewhere"
    start.mkdir()
    elsewhere.mkdir()
    monkeypatch.chdir(start)
    theta = np.random.default_rng(9).uniform(-1.0, 1.0, (3000, 2))

    def model(batch):
        os.chdir(elsewhere)
        return np.column_stack([batch[:, 0], batch[:, 1], batch.sum(axis=1)])

    t = Thresholds(np.full(N_M, -0.8), np.full(N_M, 0.8))
    plain = edmf_rs.falsify_model(model, theta, np.zeros(N_M), t, batch_size=500, progress=False)
    os.chdir(start)
    saved = edmf_rs.falsify_model(model, theta, np.zeros(N_M), t, batch_size=500, progress=False,
                                  checkpoint="run", checkpoint_every=0)
    np.testing.assert_array_equal(saved.candidate_indices, plain.candidate_indices)
    assert (start / "run" / "state.json").is_file() and not (elsewhere / "run").exists()
