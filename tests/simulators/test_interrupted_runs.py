"""Ctrl-C during external runs: the solver in progress is killed, what finished
is kept in the prediction store, and the next run reuses it."""

import doctest
import importlib
import json
import os
import signal
import subprocess
import sys
import time

import pandas as pd
import pytest
from conftest import command_model, write_project
from edmf_rs import cli


def test_ctrl_c_kills_the_running_solver_and_keeps_what_finished(folder, tmp_path):
    project = write_project(folder, command_model("sleep_high_a"), n=8)  # instance 1 has a > 1.5: it hangs
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "edmf_rs", "run", str(project), "--out", str(out), "--no-progress"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not list(out.glob("work/instance-000000001-*/pid")) and time.monotonic() < deadline:
        time.sleep(0.02)
    pid_file = next(out.glob("work/instance-000000001-*/pid"))
    time.sleep(0.1)
    solver = int(pid_file.read_text())
    started = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=50)
    assert time.monotonic() - started < 50  # not the 60 s the solver would sleep
    assert proc.returncode == 130, err
    with pytest.raises(ProcessLookupError):
        os.kill(solver, 0)
    stored = pd.concat([pd.read_parquet(p) for p in out.glob("store/*/part-*.parquet")])
    assert stored["instance"].tolist() == [0] and not stored["failed"].any()
    # The next run reuses instance 0 (instance 1 hangs again: stop it with a timeout).
    project = write_project(folder, command_model("sleep_high_a", timeout=0.5), n=8, sd=5.0)
    assert cli.main(["run", str(project), "--out", str(out), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reused_evaluations"] == 1 and summary["model_evaluations"] == 7


@pytest.mark.parametrize("module", ["template", "parsers", "failures", "command", "store", "evaluator", "pool"])
def test_docstring_examples(module):
    result = doctest.testmod(importlib.import_module(f"edmf_rs.simulators.{module}"))
    assert result.attempted > 0 and result.failed == 0
