"""What a run takes from the prediction store is held to the same rules as what
it evaluates: `edmf-rs falsify` runs nothing and leaves the store as it was,
failures reused from the store count against max_failure_rate and
stop_after_failures and are written to failures.csv as plain numbers, an
external program's results are reported as matched by sensor name, and a
malformed --scheduler address is refused at once (exit 2)."""

import json
import os
import subprocess
import sys

import pandas as pd
import pytest
from conftest import command_model, write_project
from edmf_rs import cli


def run(project, out, *extra):
    return cli.main(["run", str(project), "--out", str(out), "--no-progress", *extra])


def summary(out):
    return json.loads((out / "summary.json").read_text())


def store_files(out):
    return sorted(p.relative_to(out) for p in (out / "store").rglob("*"))


def test_falsify_from_a_store_evaluates_nothing_and_leaves_the_store_alone(folder, tmp_path, capsys):
    out, again = tmp_path / "out", tmp_path / "again"
    short = write_project(folder, command_model("slow_high_a=1.2", timeout=0.4, workers=2), n=16)
    assert run(short, out) == 0
    n_failed = summary(out)["failed_instances"]
    assert n_failed > 0
    before = store_files(out)
    # A longer timeout: `run` would retry the timed-out instances; `falsify` must not.
    longer = write_project(folder, command_model("slow_high_a=1.2", timeout=5, workers=2), n=16)
    capsys.readouterr()
    code = cli.main(["falsify", str(out), "--project", str(longer), "--out", str(again), "--no-progress"])
    assert code == 0
    got = summary(again)
    assert (got["model_evaluations"], got["reused_evaluations"], got["failed_instances"]) == (0, 16, n_failed)
    assert got["failures_not_retried"] == n_failed and "timed out" in got["failures_not_retried_note"]
    assert store_files(out) == before  # no retry-*.parquet added to the source store
    assert not (again / "work").exists()
    assert len(pd.read_csv(again / "failures.csv")) == n_failed
    text = capsys.readouterr().out
    assert f"{n_failed} failed instances timed out under a shorter timeout" in text


def test_failures_reused_from_the_store_are_written_as_plain_numbers(folder, tmp_path):
    out = tmp_path / "out"
    project = write_project(folder, command_model("fail_high_a"), sd=5.0, n=16)
    assert run(project, out) == 0
    first = (out / "failures.csv").read_text()
    assert run(project, out) == 0 and summary(out)["model_evaluations"] == 0
    again = (out / "failures.csv").read_text()
    assert "np.float64" not in again and again == first
    assert cli.main(["falsify", str(out), "--project", str(project), "--out", str(tmp_path / "f"),
                     "--no-progress"]) == 0
    assert (tmp_path / "f" / "failures.csv").read_text() == first


@pytest.mark.parametrize("limit", ["max_failure_rate = 0.2", "stop_after_failures = 2"])
def test_the_failure_policy_counts_failures_reused_from_the_store(folder, tmp_path, capsys, limit):
    # "fail" makes every instance fail: no limit at first, then one that the failures exceed.
    out = tmp_path / "out"
    assert run(write_project(folder, command_model("fail", stop_after_failures=0), n=11), out) == 0
    assert summary(out)["failed_instances"] == 11
    key, value = limit.split(" = ")
    limited = write_project(folder, command_model("fail", **{"stop_after_failures": 0, key: value}), n=11)
    capsys.readouterr()
    fresh_code = run(limited, tmp_path / "fresh")
    fresh_err = capsys.readouterr().err
    assert fresh_code == 1 and "model runs stopped" in fresh_err
    code = run(limited, out, "--force")
    err = capsys.readouterr().err
    assert code == 1, "reused failures must stop the run as new ones do"
    assert "model runs stopped" in err and err.splitlines()[0] in fresh_err
    # falsify from the store obeys the same limit.
    code = cli.main(["falsify", str(out), "--project", str(limited), "--out", str(tmp_path / "f"), "--no-progress"])
    assert code == 1 and "model runs stopped" in capsys.readouterr().err


def test_a_command_models_results_are_reported_as_matched_by_name(folder, tmp_path, capsys):
    out = tmp_path / "out"
    assert run(write_project(folder, command_model(), n=8), out) == 0
    assert summary(out)["identification"]["sensor_mapping"]["how"] == "by name"
    text = capsys.readouterr().out
    assert "matched to the sensors by name" in text and "by position" not in text


@pytest.mark.parametrize("address", ["not-an-address", "tcp://[::1", "inproc://x", ""])
def test_a_malformed_scheduler_address_exits_2_at_once(folder, tmp_path, address):
    # In a process of its own, as typed: a half-made Dask client blocked ~10 s at exit and
    # printed "Exception ignored in: Client.__del__ ... TimeoutError" (no timing asserted here).
    project = write_project(folder, 'function = "lin_model:predict"', n=16)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    done = subprocess.run([sys.executable, "-m", "edmf_rs", "run", str(project), "--out", str(tmp_path / "out"),
                           "--no-progress", "--scheduler", address], capture_output=True, text=True, env=env,
                          cwd=folder, timeout=120)
    assert done.returncode == 2, done.stderr
    assert "--scheduler" in done.stderr and project.name in done.stderr
    assert "Exception ignored" not in done.stderr and "TimeoutError" not in done.stderr
    assert not (tmp_path / "out" / "summary.json").exists()
