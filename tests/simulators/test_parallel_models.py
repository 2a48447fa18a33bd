"""workers = N: the same result as one worker, for Python models (spawned
processes) and external programs (threads waiting on subprocesses)."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import command_model, write_project
from edmf_rs import cli
from edmf_rs.simulators import Evaluator
from edmf_rs.simulators.pool import FunctionPool


def run(project, out, *extra):
    code = cli.main(["run", str(project), "--out", str(out), "--no-progress", *extra])
    return code, (json.loads((out / "summary.json").read_text()) if code == 0 else None)


@pytest.mark.parametrize("model", ['function = "lin_model:predict"\nbatch_size = 100', command_model()])
def test_two_workers_give_the_one_worker_result(folder, tmp_path, model):
    project = write_project(folder, model, n=256 if "function" in model else 32)
    one = run(project, tmp_path / "one", "--workers", "1")[1]
    two = run(project, tmp_path / "two", "--workers", "2")[1]
    assert one["candidates"] == two["candidates"] and one["model_evaluations"] == two["model_evaluations"]
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "one" / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "two" / "candidates.parquet"))


def test_function_pool_matches_the_function_on_any_split(folder):
    rng = np.random.default_rng(0)
    with FunctionPool("lin_model:predict", folder, {}, workers=2) as pool:
        for n in (1, 2, 3, 17):
            theta = rng.uniform(0, 2, (n, 2))
            expected = theta[:, 0:1] * np.array([1.0, 2.0, 0.5, -1.0]) + theta[:, 1:2] * np.array([0.3, -0.2, 1.5, 0.8])
            assert np.array_equal(pool(theta, first=0), expected)


def test_a_worker_process_that_dies_names_the_instances(folder, tmp_path, capsys):
    (folder / "dying.py").write_text(textwrap.dedent("""
        import os, signal
        def predict(theta):
            os.kill(os.getpid(), signal.SIGKILL)   # like the OOM killer
    """))
    project = write_project(folder, 'function = "dying:predict"\nworkers = 2\nbatch_size = 16', n=32)
    code, _ = run(project, tmp_path / "out")
    assert code == 1
    err = capsys.readouterr().err
    assert "worker process evaluating model.function = 'dying:predict' on instances 0..15 died" in err


def test_evaluator_in_memory_without_an_output_folder(folder):
    import sys
    sys.path.insert(0, str(folder))
    from lin_model import predict

    ev = Evaluator(("a", "b"), ("S1", "S2", "S3", "S4"), 4, function=predict, ref="lin_model:predict",
                   path=folder, workers=2)
    theta = np.array([[1.0, 1.0], [0.5, 2.0], [0.0, 0.0]])
    try:
        assert np.array_equal(ev(theta), predict(theta))
    finally:
        ev.close()
    assert ev.stats()["prediction_store"] is None and ev.model_evaluations == 3


def test_ctrl_c_stops_the_worker_processes_of_a_slow_model(folder, tmp_path):
    """SIGINT to the run alone (not its workers): exit 130 at once, the
    workers stopped, not waited for (they would sleep ten minutes)."""
    (folder / "slow.py").write_text(textwrap.dedent("""
        import os, time
        def predict(theta):
            open(f"started-{os.getpid()}", "w").close()
            time.sleep(600)
    """))
    project = write_project(folder, 'function = "slow:predict"\nworkers = 2\nbatch_size = 16', n=32)
    proc = subprocess.Popen([sys.executable, "-m", "edmf_rs", "run", str(project), "--out", str(tmp_path / "out"),
                             "--no-progress"], cwd=folder, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.monotonic() + 120
    while len(list(folder.glob("started-*"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    workers = [int(p.name.split("-")[1]) for p in folder.glob("started-*")]
    assert len(workers) == 2
    proc.send_signal(signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)  # a hang fails here, long before the model's ten minutes
    except subprocess.TimeoutExpired:
        for pid in (proc.pid, *workers):
            os.kill(pid, signal.SIGKILL)
        raise
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    deadline = time.monotonic() + 60  # SIGTERM takes effect asynchronously
    while any(map(_running, workers)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(map(_running, workers))


def _running(pid: int) -> bool:
    """Whether process `pid` exists and is not a zombie (one waiting to be reaped has stopped)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


def test_a_failing_model_with_two_workers_names_an_instance_that_fails(folder, tmp_path, capsys):
    """The model's own error leaves the workers running, so the search for the
    first failing instance runs the model again (a stopped pool had every call
    fail and named instance 0, which passes)."""
    (folder / "diverging.py").write_text(textwrap.dedent("""
        from lin_model import predict as linear
        def predict(theta):
            if (theta[:, 0] > 1.5).any():
                raise ValueError("diverged")
            return linear(theta)
    """))
    project = write_project(folder, 'function = "diverging:predict"\nworkers = 2\nbatch_size = 16', n=32)
    code, _ = run(project, tmp_path / "out")
    assert code == 1
    err = capsys.readouterr().err
    assert "raised ValueError: diverged, on batch 0 (instances 0..15); first failing instance:" in err
    a = float(err.split("first failing instance:")[1].split("(a=")[1].split(",")[0])
    assert a > 1.5
