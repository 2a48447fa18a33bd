"""A checkpoint's first save: before it writes any part, a state with nothing
done claims the part names, so a folder without a state claims none.

Was: a folder holding only ``.lock`` (a run stopped before its first save)
let the next run overwrite a user's file named like a first part. A crash
(SIGKILL) during the first save still resumes, a full disk during it leaves
the folder as it was, and a state with nothing done is any call's to start
over in."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import textwrap

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds
from edmf_rs.stream import checkpoint

N_M, ROWS, CHUNK = 3, 600, 100
USER = b"the user's own data"


def _case(half_width=1.2):
    predictions = np.random.default_rng(11).normal(0.0, 1.0, (ROWS, N_M))
    return predictions, np.zeros(N_M), Thresholds(np.full(N_M, -half_width), np.full(N_M, half_width))


def _violated(predictions, y, thresholds):
    residual = predictions - y
    return ~((residual >= thresholds.low) & (residual <= thresholds.high))


def _model(theta):
    return np.column_stack([theta[:, 0], theta[:, 1], theta[:, 0] - theta[:, 1]])


def _theta():
    return np.random.default_rng(12).normal(0.0, 1.0, (ROWS, 2))


def _check(result, predictions, y, thresholds, violations=True):
    """``result`` against NumPy's reading of Eq. 8 (no NaN in these inputs)."""
    violated = _violated(predictions, y, thresholds)
    assert result.n_instances == len(predictions)
    np.testing.assert_array_equal(result.candidate_indices, np.flatnonzero(~violated.any(axis=1)))
    np.testing.assert_array_equal(result.per_sensor_falsified, violated[violated.any(axis=1)].sum(axis=0))
    if violations:
        np.testing.assert_array_equal(result.n_violated, violated.sum(axis=1))


def _state(folder):
    return json.loads((folder / "state.json").read_text())


def _listed(folder):
    """The files a finished run's folder may hold: its state, lock and listed parts."""
    state = _state(folder)
    fields = {name for part in state["parts"] for name in part["sha256"]}
    return {"state.json", ".lock"} | {f"part-{k:06d}.{name}.npy" for k in range(len(state["parts"])) for name in fields}


# -- a folder left by a run stopped before its first save ---------------------

def _stopped_before_the_first_save(folder, call):
    predictions, y, thresholds = _case()

    def chunks():  # Ctrl-C while the first chunk is read
        raise KeyboardInterrupt
        yield

    def model(theta):  # Ctrl-C in the first model call
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        if call == "falsify":
            edmf_rs.falsify(chunks(), y, thresholds, keep_violations=True, checkpoint=folder, progress=False)
        else:
            edmf_rs.falsify_model(model, _theta(), y, thresholds, batch_size=CHUNK, checkpoint=folder,
                                  progress=False)
    assert {p.name for p in folder.iterdir()} == {".lock"}


def _run(folder, call):
    predictions, y, thresholds = _case()
    if call == "falsify":
        return edmf_rs.falsify(predictions, y, thresholds, keep_violations=True, chunk_rows=CHUNK,
                               checkpoint=folder, checkpoint_every=0, progress=False)
    return edmf_rs.falsify_model(_model, _theta(), y, thresholds, batch_size=CHUNK, checkpoint=folder,
                                 checkpoint_every=0, progress=False)


@pytest.mark.parametrize("call, field", [("falsify", "candidates"), ("falsify", "n_violated"),
                                         ("model", "candidates"), ("model", "parameters"),
                                         ("model", "predictions")])
def test_a_users_file_beside_the_lock_of_a_run_stopped_before_its_first_save_is_kept(tmp_path, call, field):
    # was: overwritten by the next run's first save, the .lock taken as a sign that a run had written it
    folder = tmp_path / "run"
    _stopped_before_the_first_save(folder, call)
    mine = folder / f"part-000000.{field}.npy"
    mine.write_bytes(USER)
    with pytest.raises(ValueError, match=rf"holds part-000000\.{field}\.npy, which is no part of the run.*move it"):
        _run(folder, call)
    assert mine.read_bytes() == USER
    assert {p.name for p in folder.iterdir()} == {".lock", mine.name}  # no state written either
    mine.rename(tmp_path / "moved")
    result = _run(folder, call)
    if call == "falsify":
        _check(result, *_case())
    else:
        _check(result, _model(_theta()), *_case()[1:], violations=False)
        np.testing.assert_array_equal(result.candidate_parameters, _theta()[result.candidate_indices])
    assert {p.name for p in folder.iterdir()} == _listed(folder)


def test_a_lone_lock_file_claims_nothing(tmp_path):
    # the same folder made by hand: .lock alone is no sign of a run's files
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / ".lock").touch()
    mine = folder / "part-000000.candidates.npy"
    mine.write_bytes(USER)
    with pytest.raises(ValueError, match=r"holds part-000000\.candidates\.npy"):
        _run(folder, "falsify")
    assert mine.read_bytes() == USER and not (folder / "state.json").exists()


# -- a crash (SIGKILL) during the first save ----------------------------------

CHILD = textwrap.dedent('''
    import os, signal, sys
    import numpy as np
    import edmf_rs
    from edmf_rs import Thresholds
    from edmf_rs.stream import atomic, checkpoint

    checkpoint.MAX_SAVE_SHARE = 1.0  # a save after every chunk, as in tests/conftest.py
    data, folder, kill_at, phase = sys.argv[1:5]
    inputs = np.load(data)
    renames = [0]
    replace = os.replace

    def dying_replace(src, dst):  # atomic.py's rename of a finished file
        renames[0] += 1
        if renames[0] == int(kill_at) and phase == "before":
            os.kill(os.getpid(), signal.SIGKILL)
        replace(src, dst)
        if renames[0] == int(kill_at) and phase == "after":
            os.kill(os.getpid(), signal.SIGKILL)

    atomic.os.replace = dying_replace
    edmf_rs.falsify(inputs["predictions"], inputs["y"], Thresholds(inputs["low"], inputs["high"]),
                    keep_violations=True, chunk_rows=int(inputs["chunk"]), checkpoint=folder,
                    checkpoint_every=0, progress=False)
''')

#: The first save's renames: its claim (a state with nothing done), its two parts, its state.
FIRST_SAVE = {(1, "before"): set(), (1, "after"): {"state.json"},
              (2, "after"): {"state.json", "part-000000.candidates.npy"},
              (3, "after"): {"state.json", "part-000000.candidates.npy", "part-000000.n_violated.npy"},
              (4, "before"): {"state.json", "part-000000.candidates.npy", "part-000000.n_violated.npy"}}


def _killed(tmp_path, kill_at, phase):
    predictions, y, thresholds = _case()
    data = tmp_path / "inputs.npz"
    np.savez(data, predictions=predictions, y=y, low=thresholds.low, high=thresholds.high, chunk=CHUNK)
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    folder = tmp_path / "run"
    proc = subprocess.run([sys.executable, str(script), str(data), str(folder), str(kill_at), phase],
                          capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    left = {p.name for p in folder.iterdir() if not p.name.endswith(".tmp")}
    assert left == {".lock"} | FIRST_SAVE[kill_at, phase]
    if "state.json" in left:  # the claim: nothing done, the first save's parts pending
        state = _state(folder)
        assert (state["n_done"], state["parts"], state["complete"]) == (0, [], False)
        assert set(state["pending"]) == {"part-000000.candidates.npy", "part-000000.n_violated.npy"}
    return folder


@pytest.mark.parametrize("kill_at, phase", sorted(FIRST_SAVE))
def test_a_crash_during_the_first_save_resumes_and_its_parts_are_overwritten(tmp_path, kill_at, phase):
    folder = _killed(tmp_path, kill_at, phase)
    _check(_run(folder, "falsify"), *_case())
    assert {p.name for p in folder.iterdir()} == _listed(folder)  # leftovers overwritten or removed
    assert len(_state(folder)["parts"]) == ROWS // CHUNK


def test_another_call_starts_over_in_a_folder_whose_run_did_nothing(tmp_path):
    # the crashed run kept violations; this call does not, and has other thresholds
    folder = _killed(tmp_path, 3, "after")
    predictions, y, _ = _case()
    thresholds = _case(half_width=1.5)[2]
    result = edmf_rs.falsify(predictions, y, thresholds, keep_violations=False, chunk_rows=CHUNK,
                             checkpoint=folder, checkpoint_every=0, progress=False)
    _check(result, predictions, y, thresholds, violations=False)
    # the crashed run's n_violated part, which this run does not write, is removed with the rest
    assert {p.name for p in folder.iterdir()} == _listed(folder)
    assert not (folder / "part-000000.n_violated.npy").exists()


def test_a_state_with_nothing_done_claims_only_the_names_it_lists(tmp_path):
    # the crashed run kept no violations: a file at the n_violated name is not its own
    folder = tmp_path / "run"
    predictions, y, thresholds = _case()
    original = checkpoint.save_state
    calls = [0]

    def crash_at_the_first_state(*args):  # after the claim and the parts, as a SIGKILL would
        calls[0] += 1
        if calls[0] == 2:
            raise SystemExit("killed")
        return original(*args)

    checkpoint.save_state = crash_at_the_first_state
    try:
        with pytest.raises(SystemExit):
            edmf_rs.falsify(predictions, y, thresholds, keep_violations=False, chunk_rows=CHUNK,
                            checkpoint=folder, checkpoint_every=0, progress=False)
    finally:
        checkpoint.save_state = original
    assert _state(folder)["pending"] == ["part-000000.candidates.npy"]
    mine = folder / "part-000000.n_violated.npy"
    mine.write_bytes(USER)
    with pytest.raises(ValueError, match=r"holds part-000000\.n_violated\.npy"):
        _run(folder, "falsify")  # keeps violations
    assert mine.read_bytes() == USER
    mine.unlink()
    _check(_run(folder, "falsify"), predictions, y, thresholds)


# -- a full disk during the first save ----------------------------------------

@pytest.mark.parametrize("writer, failing", [("save_state", 1), ("save_npy", 1), ("save_npy", 2), ("save_state", 2)])
def test_a_full_disk_during_the_first_save_leaves_the_folder_as_it_was(tmp_path, monkeypatch, full_disk, writer,
                                                                       failing):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "notes.txt").write_bytes(USER)
    original = getattr(checkpoint, writer)
    full_disk(writer, failing)
    with pytest.raises(checkpoint.CheckpointError, match="No space left on device.*Nothing was saved") as info:
        _run(folder, "falsify")
    assert info.value.errno == errno.ENOSPC
    assert {p.name for p in folder.iterdir()} == {"notes.txt", ".lock"}  # no state, no part, no temporary
    assert (folder / "notes.txt").read_bytes() == USER
    monkeypatch.setattr(checkpoint, writer, original)
    _check(_run(folder, "falsify"), *_case())


def test_a_full_disk_when_resuming_a_run_that_did_nothing_keeps_its_state(tmp_path, monkeypatch, full_disk):
    folder = _killed(tmp_path, 2, "after")
    before = (folder / "state.json").read_bytes()
    full_disk("save_npy")  # the resumed run's first part
    with pytest.raises(checkpoint.CheckpointError, match="still holds the state after instance 0"):
        _run(folder, "falsify")
    assert (folder / "state.json").read_bytes() == before
    monkeypatch.undo()
    _check(_run(folder, "falsify"), *_case())
