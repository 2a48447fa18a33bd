"""Stored failures are run again when they could now succeed: a timed-out
instance when the project's timeout is larger than the one it failed under,
and every failure with --retry-failures; exit-code failures are not retried
by default (the same run would fail the same way)."""

import json

import pandas as pd
from conftest import command_model, write_project
from edmf_rs import cli


def run(project, out, *extra):
    assert cli.main(["run", str(project), "--out", str(out), "--no-progress", *extra]) == 0
    return json.loads((out / "summary.json").read_text())


def failures(out):
    return pd.read_csv(out / "failures.csv")


def test_instances_that_timed_out_run_again_under_a_longer_timeout(folder, tmp_path):
    out = tmp_path / "out"
    short = run(write_project(folder, command_model("slow_high_a=1.2", timeout=0.4, workers=2), n=16), out)
    timed_out = failures(out)
    assert short["failed_instances"] == len(timed_out) > 0
    assert timed_out["reason"].str.startswith("timed out after 0.4 s").all()
    # The same timeout: the failures are reused, nothing runs.
    same = run(write_project(folder, command_model("slow_high_a=1.2", timeout=0.4, workers=2), n=16), out)
    assert (same["model_evaluations"], same["reused_evaluations"], same["failed_instances"]) == \
        (0, 16, short["failed_instances"])
    # A shorter one cannot help either.
    shorter = run(write_project(folder, command_model("slow_high_a=1.2", timeout=0.3, workers=2), n=16), out)
    assert (shorter["model_evaluations"], shorter["failed_instances"]) == (0, short["failed_instances"])
    # A longer one runs exactly the instances that timed out, and they succeed.
    longer_project = write_project(folder, command_model("slow_high_a=1.2", timeout=5, workers=2), n=16)
    longer = run(longer_project, out)
    assert (longer["model_evaluations"], longer["reused_evaluations"], longer["failed_instances"]) == \
        (len(timed_out), 16 - len(timed_out), 0)
    assert failures(out).empty
    fresh = run(longer_project, tmp_path / "fresh")
    assert fresh["failed_instances"] == 0 and longer["candidates"] == fresh["candidates"]
    pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "fresh" / "candidates.parquet"))
    # The retried results replace the failures in the store: the next run evaluates nothing.
    again = run(longer_project, out)
    assert (again["model_evaluations"], again["failed_instances"]) == (0, 0)


def test_exit_code_failures_run_again_only_on_request(folder, tmp_path, monkeypatch):
    out = tmp_path / "out"
    project = write_project(folder, command_model("fail_high_a_env"), sd=5.0, n=32)
    monkeypatch.setenv("STANDIN_FAIL", "1")
    first = run(project, out)
    n_failed = first["failed_instances"]
    assert n_failed > 0 and failures(out)["reason"].str.startswith("exit code 4").all()
    monkeypatch.delenv("STANDIN_FAIL")  # the cause is gone (a licence server answers again) ...
    reused = run(project, out)  # ... but a failure that is no timeout is reused by default
    assert (reused["model_evaluations"], reused["failed_instances"]) == (0, n_failed)
    retried = run(project, out, "--retry-failures")
    assert (retried["model_evaluations"], retried["reused_evaluations"], retried["failed_instances"]) == \
        (n_failed, 32 - n_failed, 0)
    fresh = run(project, tmp_path / "fresh")
    assert retried["candidates"] == fresh["candidates"] > 0
    pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "fresh" / "candidates.parquet"))


def test_retried_instances_that_fail_again_are_counted_once(folder, tmp_path):
    out = tmp_path / "out"
    project = write_project(folder, command_model("fail_high_a"), sd=5.0, n=32)
    first = run(project, out)
    retried = run(project, out, "--retry-failures")
    assert retried["model_evaluations"] == first["failed_instances"] > 0
    assert retried["failed_instances"] == first["failed_instances"]
    assert len(failures(out)) == first["failed_instances"]
    assert failures(out)["instance"].is_unique
