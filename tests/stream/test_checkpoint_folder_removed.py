"""A checkpoint folder removed, emptied or replaced while a run saves into it
stops the run at its next save, naming the folder. Before, the saves
recreated the folder and the run failed only when it read the parts back at
the end, after all the work, because the first parts were gone."""

from __future__ import annotations

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
    with pytest.raises(CheckpointError, match=rf"checkpoint: folder {folder} was removed or emptied during the "
                                              rf"run, with the {AT * ROWS} instances saved there"):
        edmf_rs.falsify(chunks(), np.zeros(N_M), t, checkpoint=folder, checkpoint_every=0, progress=False,
                        trust_iterable=True)
    assert drawn == list(range(AT + 1))  # stopped at the save after the change, not at the end
    assert not (folder / "state.json").exists()  # no state recreated that would miss the first parts
