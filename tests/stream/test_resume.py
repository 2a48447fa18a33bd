"""Resumable runs: whatever stops a checkpointed run (SIGKILL at any point,
Ctrl-C, a model error, a full disk), running the same call again ends with
exactly the result of an uninterrupted run."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds, reference
from edmf_rs.stream import checkpoint

N_M = 5
ROWS = 20_000
CHUNK = 500


def _case(n=ROWS, seed=0):
    rng = np.random.default_rng(seed)
    predictions = rng.normal(0.0, 1.0, (n, N_M))
    predictions[rng.random(n) < 0.6] *= 0.3
    predictions[7::301, 3] = np.nan
    return predictions, np.zeros(N_M), Thresholds(np.full(N_M, -1.2), np.full(N_M, 1.2))


def _same(got, want):
    assert got.n_instances == want.n_instances
    np.testing.assert_array_equal(got.candidate_indices, want.candidate_indices)
    for name in ("per_sensor_falsified", "falsified_only_by", "n_invalid", "n_violated",
                 "candidate_parameters", "candidate_predictions"):
        a, b = getattr(got, name), getattr(want, name)
        assert (a is None) == (b is None), name
        if a is not None:
            np.testing.assert_array_equal(a, b, err_msg=name)
            assert np.asarray(a).dtype == np.asarray(b).dtype, name


def _state(folder):
    path = folder / "state.json"
    return json.loads(path.read_text()) if path.exists() else {"n_done": 0, "complete": False}


def _model(theta):
    i = np.arange(N_M)
    return theta[:, :1] * (1.0 + 0.2 * i) - theta[:, 1:2] * (i - 1.5)


#: Module-level state of spy models (closure values are part of a model's fingerprint).
SPY: dict = {}
#: Calls a spy model counts (see test_an_unwritable_folder_is_refused_before_any_work).
CALLS: list[int] = []


def _theta(n=ROWS):
    return np.random.default_rng(5).uniform(-1.0, 1.0, (n, 2))


# -- a run in a child process that SIGKILLs itself at a chosen point ---------

CHILD = textwrap.dedent('''
    import os, signal, sys
    import numpy as np
    import edmf_rs
    from edmf_rs import Thresholds
    from edmf_rs.stream import atomic, checkpoint

    checkpoint.MAX_SAVE_SHARE = 1.0  # a save after every chunk: the kill points count on it (tests/conftest.py)
    mode, data, folder, kill_at, phase, out = sys.argv[1:7]
    kill_at = int(kill_at)
    inputs = np.load(data)
    y, t = inputs["y"], Thresholds(inputs["low"], inputs["high"])
    renames = [0]
    replace = os.replace

    def dying_replace(src, dst):  # atomic.py's rename of a finished file
        renames[0] += 1
        if renames[0] == kill_at and phase == "before":
            os.kill(os.getpid(), signal.SIGKILL)
        replace(src, dst)
        if renames[0] == kill_at and phase == "after":
            os.kill(os.getpid(), signal.SIGKILL)

    atomic.os.replace = dying_replace
    calls = [0]
    # In a dict: the model's fingerprint hashes the simple module-level values
    # it reads (a str or int here would make the killed run another model).
    control = {"phase": phase, "kill_at": kill_at}

    def model(theta):
        calls[0] += 1
        if control["phase"] == "model" and calls[0] == control["kill_at"]:
            os.kill(os.getpid(), signal.SIGKILL)
        i = np.arange(y.shape[0])
        return theta[:, :1] * (1.0 + 0.2 * i) - theta[:, 1:2] * (i - 1.5)

    if mode == "file":
        result = edmf_rs.falsify(inputs["path"].item(), y, t, chunk_rows=int(inputs["chunk"]),
                                 checkpoint=folder, checkpoint_every=0, progress=False)
    else:
        theta = inputs["theta"]
        batches = (theta[i:i + 700] for i in range(0, len(theta), 700))
        result = edmf_rs.falsify_model(model, batches, y, t, checkpoint=folder,
                                       checkpoint_every=0, progress=False)
        np.savez(out, candidates=result.candidate_indices, parameters=result.candidate_parameters,
                 predictions=result.candidate_predictions, per_sensor=result.per_sensor_falsified,
                 only_by=result.falsified_only_by, n=result.n_instances, calls=calls[0])
''')


def _child(tmp_path, mode, data, folder, kill_at=0, phase="none"):
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    out = tmp_path / "out.npz"
    return subprocess.run([sys.executable, str(script), mode, str(data), str(folder), str(kill_at), phase,
                           str(out)], capture_output=True, text=True, timeout=120, check=False), out


def _inputs(tmp_path, **arrays):
    _, y, t = _case()
    data = tmp_path / "inputs.npz"
    np.savez(data, y=y, low=t.low, high=t.high, **arrays)
    return data


def test_sigkill_at_random_points_then_resume_file(tmp_path):
    predictions, y, t = _case()
    path = tmp_path / "p.npy"
    np.save(path, predictions.astype(np.float32))
    data = _inputs(tmp_path, path=str(path), chunk=CHUNK)
    folder = tmp_path / "run"
    rng = np.random.default_rng()  # a new random point every time: any point must do
    n_renames = 2 * ROWS // CHUNK  # a candidates part and the state per chunk
    for attempt in range(2):
        kill_at, phase = int(rng.integers(1, n_renames // 2)), str(rng.choice(["before", "after"]))
        done = _state(folder)["n_done"]
        proc, _ = _child(tmp_path, "file", data, folder, kill_at, phase)
        where = f"attempt {attempt}: killed at rename {kill_at} ({phase})"
        assert proc.returncode == -signal.SIGKILL, where + proc.stderr
        state = _state(folder)
        assert done <= state["n_done"] < ROWS and state["n_done"] % CHUNK == 0, where
    resumed = edmf_rs.falsify(path, y, t, chunk_rows=CHUNK, checkpoint=folder, checkpoint_every=0)
    _same(resumed, edmf_rs.falsify(path, y, t, chunk_rows=CHUNK))
    want = reference.falsify(predictions.astype(np.float32), y, t)
    np.testing.assert_array_equal(resumed.candidate_indices, want.candidate_indices)
    np.testing.assert_array_equal(resumed.per_sensor_falsified, want.per_sensor_falsified)
    assert not list(folder.glob(".*.tmp"))  # leftovers of killed writes are tidied at the end


def test_sigkill_in_model_or_write_then_resume_model(tmp_path):
    theta = _theta(7_000)
    _, y, t = _case()
    data = _inputs(tmp_path, theta=theta)
    folder = tmp_path / "run"
    rng = np.random.default_rng()
    kill_batch = int(rng.integers(3, 10))
    proc, _ = _child(tmp_path, "model", data, folder, kill_batch, "model")
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    done = _state(folder)["n_done"]
    # Killed in the k-th model call: batches up to k-2 are saved (k-1 was being falsified).
    assert done == (kill_batch - 2) * 700
    kill_at = int(rng.integers(1, 6))
    proc, _ = _child(tmp_path, "model", data, folder, kill_at, str(rng.choice(["before", "after"])))
    assert proc.returncode == -signal.SIGKILL, proc.stderr
    assert _state(folder)["n_done"] >= done
    resumed_from = _state(folder)["n_done"]
    proc, out = _child(tmp_path, "model", data, folder)
    assert proc.returncode == 0, proc.stderr
    got = np.load(out)
    assert got["calls"] == -(-(7_000 - resumed_from) // 700)  # done batches were not evaluated again
    want = edmf_rs.falsify_model(_model, (theta[i:i + 700] for i in range(0, 7_000, 700)), y, t)
    assert got["n"] == want.n_instances
    np.testing.assert_array_equal(got["candidates"], want.candidate_indices)
    np.testing.assert_array_equal(got["parameters"], want.candidate_parameters)
    np.testing.assert_array_equal(got["predictions"], want.candidate_predictions)
    np.testing.assert_array_equal(got["per_sensor"], want.per_sensor_falsified)
    np.testing.assert_array_equal(got["only_by"], want.falsified_only_by)


def test_sigkill_from_outside_at_a_random_time(tmp_path):
    predictions, y, t = _case(60_000)
    path = tmp_path / "p.npy"
    np.save(path, predictions)
    data = _inputs(tmp_path, path=str(path), chunk=200)
    folder = tmp_path / "run"
    script = tmp_path / "child.py"
    script.write_text(CHILD)
    proc = subprocess.Popen([sys.executable, str(script), "file", str(data), str(folder), "0", "none", "-"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while not (folder / "state.json").exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.005)
        time.sleep(float(np.random.default_rng().uniform(0.0, 0.2)))
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait()
    resumed = edmf_rs.falsify(path, y, t, chunk_rows=200, checkpoint=folder)
    _same(resumed, edmf_rs.falsify(path, y, t))


# -- the same call again ---------------------------------------------------

@pytest.mark.parametrize("kind", ["file", "array", "iterable"])
def test_checkpointed_run_equals_plain_run_and_reloads(tmp_path, kind):
    predictions, y, t = _case()
    path = tmp_path / "p.npy"
    np.save(path, predictions)
    source = {"file": lambda: path, "array": lambda: predictions,
              "iterable": lambda: (predictions[i:i + 999] for i in range(0, ROWS, 999))}[kind]
    folder = tmp_path / "run"
    got = edmf_rs.falsify(source(), y, t, chunk_rows=CHUNK, checkpoint=folder, checkpoint_every=0)
    _same(got, edmf_rs.falsify(source(), y, t))
    assert _state(folder)["complete"] and len(_state(folder)["parts"]) > 10
    # A generator is not drawn again to be checked unless trusted; the others are re-read in full.
    _same(edmf_rs.falsify(source(), y, t, checkpoint=folder, trust_iterable=kind == "iterable"), got)


def test_refuses_to_resume_with_other_inputs(tmp_path):
    predictions, y, t = _case()
    folder = tmp_path / "run"
    chunks = [predictions[i:i + 1000] for i in range(0, ROWS, 1000)]

    def interrupted(pieces, stop_at):
        for k, piece in enumerate(pieces):
            if k == stop_at:
                raise KeyboardInterrupt
            yield piece

    with pytest.raises(KeyboardInterrupt):
        edmf_rs.falsify(interrupted(chunks, 5), y, t, checkpoint=folder, checkpoint_every=3600)
    assert _state(folder)["n_done"] == 5000  # Ctrl-C saved the chunks done
    with pytest.raises(ValueError, match="other measurements"):
        edmf_rs.falsify(chunks, y + 0.1, t, checkpoint=folder)
    with pytest.raises(ValueError, match="other thresholds"):
        edmf_rs.falsify(chunks, y, Thresholds(t.low, t.high * 2), checkpoint=folder)
    with pytest.raises(ValueError, match="other diagnostics"):
        edmf_rs.falsify(chunks, y, t, diagnostics=False, keep_violations=False, checkpoint=folder)
    with pytest.raises(ValueError, match="other n_instances"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder)
    changed = [c.copy() for c in chunks]
    for k, i in [(4, -1), (0, 0), (2, 17)]:  # the last instance done, the first, one between
        changed = [c.copy() for c in chunks]
        changed[k][i, 0] += 1e-9
        with pytest.raises(ValueError, match=r"predictions differ from the run saved .* in instances 0\.\.4999"):
            edmf_rs.falsify(changed, y, t, checkpoint=folder)
    with pytest.raises(ValueError, match="ended after 3000 instances"):
        edmf_rs.falsify(chunks[:3], y, t, checkpoint=folder)
    assert _state(folder)["n_done"] == 5000  # refusals leave the folder alone
    _same(edmf_rs.falsify(chunks, y, t, checkpoint=folder), edmf_rs.falsify(predictions, y, t))


def test_finishing_tidies_only_the_files_the_run_wrote(tmp_path):
    predictions, y, t = _case()
    folder = tmp_path / "run"
    chunks = [predictions[i:i + CHUNK] for i in range(0, ROWS, CHUNK)]

    def stop_after(k):
        for i, c in enumerate(chunks):
            if i == k:
                raise KeyboardInterrupt
            yield c

    with pytest.raises(KeyboardInterrupt):
        edmf_rs.falsify(stop_after(8), y, t, checkpoint=folder)
    n_parts = len(_state(folder)["parts"])
    token = "0123456789abcdef" * 2  # atomic.py's temporary names: .<name>.<pid>.<32 hex>.tmp
    # What a crash can leave: temporaries of the files the state lists.
    ours = [f".part-000000.candidates.npy.77.{token}.tmp", f".state.json.77.{token}.tmp"]
    # Files that only look like ours: a part the state does not list, temporaries of other names.
    theirs = ["results.csv", ".draft.tmp", "part-000001.simulation.npy", "part-x.candidates.npy",
              f"part-{n_parts + 5:06d}.candidates.npy", f".notes.txt.77.{token}.tmp",
              ".state.json.77.cd34.tmp"]
    for name in ours + theirs:
        (folder / name).write_bytes(b"left over")
    _same(edmf_rs.falsify(iter(chunks), y, t, checkpoint=folder), edmf_rs.falsify(predictions, y, t))
    left = {p.name for p in folder.iterdir()}
    assert not left & set(ours)
    assert set(theirs) <= left


def test_an_unwritable_folder_is_refused_before_any_work(tmp_path, monkeypatch):
    predictions, y, t = _case(100)
    predictions = np.nan_to_num(predictions)
    calls = CALLS  # module-level: a closure over a growing list would make each call another model
    calls.clear()

    def model(p):
        CALLS.append(len(p))
        return predictions[:len(p)]

    (tmp_path / "a-file").write_text("x")
    with pytest.raises(ValueError, match="checkpoint: cannot create folder"):
        edmf_rs.falsify_model(model, np.zeros((100, 1)), y, t, checkpoint=tmp_path / "a-file" / "run")
    # An existing folder without write access (root ignores modes: simulated).
    folder = tmp_path / "run"
    folder.mkdir()
    from edmf_rs.stream import folder_lock

    def no_write(*args, **kwargs):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))

    monkeypatch.setattr(folder_lock.tempfile, "TemporaryFile", no_write)
    with pytest.raises(ValueError, match="checkpoint: cannot write in folder .*Permission denied"):
        edmf_rs.falsify_model(model, np.zeros((100, 1)), y, t, checkpoint=folder)
    assert calls == []
    # ... while a finished run there can still be read back.
    monkeypatch.undo()
    want = edmf_rs.falsify_model(model, np.zeros((100, 1)), y, t, checkpoint=folder)
    monkeypatch.setattr(folder_lock.tempfile, "TemporaryFile", no_write)
    _same(edmf_rs.falsify_model(model, np.zeros((100, 1)), y, t, checkpoint=folder), want)


def test_a_lock_file_this_user_cannot_write_does_not_stop_a_run(tmp_path, monkeypatch):
    # A shared folder where another user's run left .lock read-only for us.
    predictions, y, t = _case(1000)
    from edmf_rs.stream import folder_lock

    def lock_read_only(path, mode="r", *args, **kwargs):
        if str(path).endswith(folder_lock.LOCK) and "r" not in mode:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return open(path, mode, *args, **kwargs)

    monkeypatch.setattr(folder_lock, "open", lock_read_only, raising=False)
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / folder_lock.LOCK).touch()
    _same(edmf_rs.falsify(predictions, y, t, checkpoint=tmp_path / "run"), edmf_rs.falsify(predictions, y, t))


@pytest.mark.parametrize("edit", [
    lambda s: s.pop("fingerprint"),
    lambda s: s.update(n_done=-1),
    lambda s: s.update(parts=None),
    lambda s: s["parts"].append({"n_instances": "3"}),
    lambda s: s["tally"]["per_sensor_falsified"].pop(),
])
def test_a_hand_edited_state_is_refused(tmp_path, edit):
    predictions, y, t = _case(1000)
    folder = tmp_path / "run"
    edmf_rs.falsify(predictions, y, t, checkpoint=folder)
    state = _state(folder)
    edit(state)
    (folder / "state.json").write_text(json.dumps(state))
    with pytest.raises(ValueError, match="state.json is not an edmf_rs checkpoint state"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder)


def test_damaged_state_is_refused(tmp_path):
    predictions, y, t = _case(100)
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "state.json").write_text("{not json")
    with pytest.raises(ValueError, match="state.json is not an edmf_rs checkpoint state"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder)
    with pytest.raises(ValueError, match="expected a folder"):
        edmf_rs.falsify(predictions, y, t, checkpoint=folder / "state.json")
    with pytest.raises(ValueError, match="checkpoint_every"):
        edmf_rs.falsify(predictions, y, t, checkpoint=tmp_path / "x", checkpoint_every=-1)


# -- Ctrl-C ------------------------------------------------------------------

def test_ctrl_c_inside_the_rust_update_then_resume(tmp_path):
    predictions, y, t = _case(500_000)
    folder = tmp_path / "run"

    def chunks():
        yield predictions[:100_000]
        # A real SIGINT, delivered while the core works on the next chunk.
        threading.Timer(0.002, os.kill, (os.getpid(), signal.SIGINT)).start()
        yield predictions[100_000:400_000]  # 1.5M predictions: two slabs, a stop check between
        while True:  # never reached uninterrupted: wait here for the signal
            time.sleep(0.01)

    with pytest.raises(KeyboardInterrupt):
        edmf_rs.falsify(chunks(), y, t, checkpoint=folder, checkpoint_every=3600)
    assert _state(folder)["n_done"] in (100_000, 400_000)
    rest = (predictions[i:i + 50_000] for i in range(0, 500_000, 50_000))
    _same(edmf_rs.falsify(rest, y, t, checkpoint=folder), edmf_rs.falsify(predictions, y, t))


def test_ctrl_c_in_the_model_then_resume_without_reevaluating(tmp_path):
    theta = _theta()
    _, y, t = _case()
    folder = tmp_path / "run"
    seen = SPY["seen"] = []
    SPY["interrupt"] = True

    def model(batch):  # its state module-level: closure values are part of the model's fingerprint
        SPY["seen"].append(batch[0].copy())
        if len(SPY["seen"]) == 9 and SPY["interrupt"]:
            raise KeyboardInterrupt
        return _model(batch)

    with pytest.raises(KeyboardInterrupt):
        edmf_rs.falsify_model(model, theta, y, t, batch_size=1000, checkpoint=folder, checkpoint_every=3600)
    assert _state(folder)["n_done"] == 8000  # batches 0..7 saved on Ctrl-C
    SPY["interrupt"], seen[:] = False, []
    resumed = edmf_rs.falsify_model(model, theta, y, t, batch_size=1000, checkpoint=folder)
    np.testing.assert_array_equal(seen[0], theta[8000])  # nothing done is evaluated again
    assert len(seen) == 12
    _same(resumed, edmf_rs.falsify_model(_model, theta, y, t, batch_size=1000))


def test_model_error_keeps_the_work_done(tmp_path):
    theta = _theta()
    _, y, t = _case()
    folder = tmp_path / "run"
    SPY["broken"] = True

    def model(batch):
        if SPY["broken"] and batch[0, 0] == theta[13_000, 0]:
            raise RuntimeError("licence server down")
        return _model(batch)

    with pytest.raises(RuntimeError, match="licence server down"):
        edmf_rs.falsify_model(model, iter(np.array_split(theta, 20)), y, t, checkpoint=folder)
    assert _state(folder)["n_done"] == 13_000
    SPY["broken"] = False
    _same(edmf_rs.falsify_model(model, iter(np.array_split(theta, 20)), y, t, checkpoint=folder),
          edmf_rs.falsify_model(_model, theta, y, t))


def test_a_folder_serves_one_run_at_a_time(tmp_path):
    theta = _theta(4_000)
    _, y, t = _case()
    folder = tmp_path / "run"
    refused = SPY["refused"] = []

    def model(batch):
        # A second run on the same folder while the first holds it is refused,
        # and leaves the first run's work alone.
        with pytest.raises(ValueError, match="in use by another run") as info:
            edmf_rs.falsify(_model(batch), y, t, checkpoint=folder)
        SPY["refused"].append(str(info.value))
        return _model(batch)

    got = edmf_rs.falsify_model(model, theta, y, t, checkpoint=folder, batch_size=1_000)
    assert len(refused) == 4
    _same(got, edmf_rs.falsify_model(_model, theta, y, t))
    # Released when the run ends: the folder is usable again at once.
    _same(edmf_rs.falsify_model(model, theta, y, t, checkpoint=folder), got)


def test_a_process_the_model_forks_does_not_keep_the_folder_locked(tmp_path):
    theta = _theta(2_000)
    _, y, t = _case()
    children = SPY["children"] = []

    def model(batch):
        if not SPY["children"]:  # e.g. a worker pool started by fork, outliving the run
            pid = os.fork()
            if pid == 0:
                time.sleep(30)
                os._exit(0)
            SPY["children"].append(pid)
        return _model(batch)

    try:
        first = edmf_rs.falsify_model(model, theta, y, t, checkpoint=tmp_path / "run", batch_size=500)
        # The child still holds the open lock file; the folder must be free anyway.
        _same(edmf_rs.falsify_model(model, theta, y, t, checkpoint=tmp_path / "run", batch_size=500), first)
    finally:
        for pid in children:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)


# -- full disk ---------------------------------------------------------------

@pytest.mark.parametrize("writer", ["save_npy", "save_state"])
def test_full_disk_gives_clear_error_and_keeps_previous_state(tmp_path, monkeypatch, full_disk, writer):
    predictions, y, t = _case()
    path = tmp_path / "p.npy"
    np.save(path, predictions)
    folder = tmp_path / "run"
    original = getattr(checkpoint, writer)
    # The 7th save's write (the first state written is the first save's claim, see test_first_save.py).
    full_disk(writer, 8 if writer == "save_state" else 7)
    with pytest.raises(OSError) as info:
        edmf_rs.falsify(path, y, t, chunk_rows=CHUNK, checkpoint=folder, checkpoint_every=0)
    assert isinstance(info.value, checkpoint.CheckpointError) and info.value.errno == errno.ENOSPC
    assert "No space left on device" in str(info.value) and str(folder) in str(info.value)
    state = _state(folder)
    assert state["n_done"] == 6 * CHUNK and not state["complete"]
    assert f"state after instance {6 * CHUNK:,}" in str(info.value)
    # The failed save's own parts do not stay behind holding the space.
    assert sorted(p.name for p in folder.glob("part-*")) == [
        f"part-{k:06d}.candidates.npy" for k in range(len(state["parts"]))]
    monkeypatch.setattr(checkpoint, writer, original)
    _same(edmf_rs.falsify(path, y, t, chunk_rows=CHUNK, checkpoint=folder, checkpoint_every=0),
          edmf_rs.falsify(path, y, t, chunk_rows=CHUNK))


def test_model_checkpoint_with_violations_and_array_parameters(tmp_path):
    theta = _theta(5_000)
    _, y, t = _case()
    folder = tmp_path / "run"

    def stops(batch):
        if batch[0, 0] == theta[3_000, 0] and not (folder / "ok").exists():
            raise KeyboardInterrupt
        return _model(batch).astype(np.float32)

    with pytest.raises(KeyboardInterrupt):
        edmf_rs.falsify_model(stops, theta, y, t, batch_size=600, keep_violations=True,
                              checkpoint=folder, checkpoint_every=0)
    (folder / "ok").touch()
    got = edmf_rs.falsify_model(stops, theta, y, t, batch_size=600, keep_violations=True, checkpoint=folder)
    want = edmf_rs.falsify_model(lambda b: _model(b).astype(np.float32), theta, y, t, batch_size=600,
                                 keep_violations=True)
    _same(got, want)
    assert got.candidate_predictions.dtype == np.float32


def test_a_finished_checkpoint_refuses_other_inputs(tmp_path):
    predictions, y, t = _case()
    other = predictions.copy()
    other[-1] += 1.0  # same shape, a different last instance
    done = edmf_rs.falsify(predictions, y, t, checkpoint=tmp_path / "run", progress=False)
    _same(edmf_rs.falsify(predictions, y, t, checkpoint=tmp_path / "run", progress=False), done)
    with pytest.raises(ValueError, match=r"predictions differ from the run saved .* instances 0\.\.19999"):
        edmf_rs.falsify(other, y, t, checkpoint=tmp_path / "run", progress=False)
    theta = _theta()
    edmf_rs.falsify_model(_model, theta, y, t, checkpoint=tmp_path / "model", progress=False)
    changed = theta.copy()
    changed[-1] += 0.5
    with pytest.raises(ValueError, match="parameters differ from the run saved"):
        edmf_rs.falsify_model(_model, changed, y, t, checkpoint=tmp_path / "model", progress=False)


def test_a_finished_checkpoint_over_a_generator_is_returned_only_when_trusted(tmp_path):
    predictions, y, t = _case()
    chunks = [predictions[i:i + CHUNK] for i in range(0, ROWS, CHUNK)]
    done = edmf_rs.falsify(iter(chunks), y, t, checkpoint=tmp_path / "run", progress=False)
    assert _state(tmp_path / "run")["rereadable"] is False  # marked: the run's input was one-pass
    drawn = []

    def drawing(blocks):
        for b in blocks:
            drawn.append(len(b))
            yield b

    with pytest.raises(ValueError, match="one-pass iterator .* trust_iterable=True"):
        edmf_rs.falsify(drawing(chunks), y, t, checkpoint=tmp_path / "run", progress=False)
    _same(edmf_rs.falsify(drawing(chunks), y, t, checkpoint=tmp_path / "run", progress=False,
                          trust_iterable=True), done)
    assert drawn == []  # trusted: not drawn at all
    _same(edmf_rs.falsify(chunks, y, t, checkpoint=tmp_path / "run", progress=False), done)  # a list: checked
    with pytest.raises(ValueError, match=r"differ from the run saved .* instances 0\.\.19999"):
        edmf_rs.falsify([predictions[::-1]], y, t, checkpoint=tmp_path / "run", progress=False)
    with pytest.raises(ValueError, match="ended after 0 instances"):
        edmf_rs.falsify([np.empty((0, N_M))], y, t, checkpoint=tmp_path / "run", progress=False)
    edmf_rs.falsify([np.empty((0, N_M))], y, t, checkpoint=tmp_path / "empty", progress=False)  # over 0
    with pytest.raises(ValueError, match="finished run over 0 instances, but the predictions have more"):
        edmf_rs.falsify(chunks, y, t, checkpoint=tmp_path / "empty", progress=False)
    theta = _theta()
    batches = [theta[i:i + 700] for i in range(0, len(theta), 700)]
    edmf_rs.falsify_model(_model, iter(batches), y, t, checkpoint=tmp_path / "model", progress=False)
    with pytest.raises(ValueError, match="parameters are a one-pass iterator"):
        edmf_rs.falsify_model(_model, iter(batches), y, t, checkpoint=tmp_path / "model", progress=False)
    with pytest.raises(ValueError, match="parameters differ from the run saved"):
        edmf_rs.falsify_model(_model, batches[::-1], y, t, checkpoint=tmp_path / "model", progress=False)
    edmf_rs.falsify_model(_model, batches, y, t, checkpoint=tmp_path / "model", progress=False)
