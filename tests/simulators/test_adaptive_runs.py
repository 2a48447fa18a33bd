"""Adaptive sampling (issue 16) with the external-program path and the
prediction store: every real run goes through the evaluator, is stored by its
parameters and is never run twice, whatever changed in the identification."""

import json
import re
import signal
import subprocess
import sys
import time

import edmf_rs
import numpy as np
import pandas as pd
import pytest
from conftest import A, command_model, write_project
from edmf_rs import cli, reference
from edmf_rs.simulators.keyed import KEYED_SCHEMA, KeyedPredictionStore

ADAPTIVE = 'method = "adaptive"\nbudget = 60\nn_initial = 20\nwave_size = 10\nn_screen = 4096\nseed = 0\n'


def adaptive_project(folder, model, name="p.toml", **kw):
    path = write_project(folder, model, name=name, **kw)
    text, k = re.subn(r'method = "sobol"\s*\n\s*n = \d+\s*\n\s*seed = 3\s*\n', ADAPTIVE, path.read_text())
    assert k == 1
    path.write_text(text)
    return path


def run(project, out):
    assert cli.main(["run", str(project), "--out", str(out), "--no-progress"]) == 0
    return json.loads((out / "summary.json").read_text())


def stored(out) -> pd.DataFrame:
    """Every row of every store part under ``out``."""
    parts = sorted(out.glob("store/*/part-*.parquet"))
    return pd.concat([pd.read_parquet(p) for p in parts], ignore_index=True) if parts else pd.DataFrame()


def test_a_command_model_gives_the_function_models_candidates_and_is_never_run_twice(folder, tmp_path):
    out = tmp_path / "out"
    first = run(adaptive_project(folder, command_model()), out)
    runs = first["adaptive"]["runs"]
    assert (first["model_evaluations"], first["reused_evaluations"]) == (runs, 0)
    rows = stored(out)
    assert len(rows) == runs and not rows.duplicated(["p:a", "p:b"]).any()
    manifest = json.loads(next(out.glob("store/*/manifest.json")).read_text())
    assert manifest["schema"] == KEYED_SCHEMA
    # The stand-in solver's outputs are the Python twin's, to the bit: the same waves, the same candidates.
    twin = edmf_rs.Project.from_toml(adaptive_project(folder, 'function = "lin_model:predict"', name="twin.toml"))
    ident = twin.run(progress=False)
    assert ident.evaluation is None  # in process, no store
    np.testing.assert_array_equal(stored(out)[["p:a", "p:b"]].to_numpy(), ident.adaptive.run_parameters)
    candidates = pd.read_parquet(out / "candidates.parquet")
    assert len(candidates) == ident.falsification.n_candidates > 0
    np.testing.assert_array_equal(candidates[list(ident.candidates.columns)].to_numpy(), ident.candidates.to_numpy())
    # Eq. 8 on the stored outputs (the NumPy reference) gives the reported candidates.
    g = rows[[f"s:S{j}" for j in range(1, 5)]].to_numpy()
    ref = reference.falsify(g, twin.measured, ident.thresholds)
    np.testing.assert_array_equal(g[ref.candidate_indices], candidates[["S1", "S2", "S3", "S4"]].to_numpy())
    # The same project again: nothing evaluated.
    again = run(adaptive_project(folder, command_model()), out)
    assert (again["model_evaluations"], again["reused_evaluations"]) == (0, runs)
    assert again["candidates"] == first["candidates"]
    # Another uncertainty: other thresholds, other waves; the runs asked for again are reused, none repeated.
    changed = run(adaptive_project(folder, command_model(), sd=0.5), out)
    assert changed["reused_evaluations"] >= 20  # the initial design at least
    assert changed["model_evaluations"] + changed["reused_evaluations"] == changed["adaptive"]["runs"]
    rows = stored(out)
    assert len(rows) == runs + changed["model_evaluations"] and not rows.duplicated(["p:a", "p:b"]).any()


def test_a_python_model_in_two_worker_processes_is_stored_by_parameters(folder, tmp_path):
    project = adaptive_project(folder, 'function = "lin_model:predict"\nworkers = 2')
    summary = run(project, tmp_path / "out")
    assert summary["model_evaluations"] == summary["adaptive"]["runs"] > 0
    in_process = edmf_rs.Project.from_toml(project).run(progress=False, workers=1)
    rows = stored(tmp_path / "out")
    np.testing.assert_array_equal(rows[["p:a", "p:b"]].to_numpy(), in_process.adaptive.run_parameters)
    theta = in_process.adaptive.run_parameters
    np.testing.assert_array_equal(rows[[f"s:S{j}" for j in range(1, 5)]].to_numpy(),
                                  theta[:, 0:1] * A[0] + theta[:, 1:2] * A[1])
    assert summary["candidates"] == in_process.falsification.n_candidates
    # Another phi: a new run in two workers reuses what is stored.
    project.write_text(project.read_text().replace("phi = 0.95", "phi = 0.9"))
    again = run(project, tmp_path / "out")
    assert again["reused_evaluations"] >= 20
    assert not stored(tmp_path / "out").duplicated(["p:a", "p:b"]).any()


def test_failed_runs_are_recorded_and_neither_candidates_nor_falsified(folder, tmp_path):
    out = tmp_path / "out"
    project = edmf_rs.Project.from_toml(adaptive_project(folder, command_model("fail_high_a"), sd=1.0))
    ident = project.run(progress=False, out=out)
    rows = stored(out)
    failed = rows["failed"].to_numpy()
    assert failed.any() and (rows.loc[failed, "p:a"] > 1.5).all() and (rows.loc[~failed, "p:a"] <= 1.5).all()
    assert ident.evaluation["failed_instances"] == failed.sum() == ident.falsification.n_invalid
    failures = pd.read_csv(out / "failures.csv")
    assert len(failures) == failed.sum() and failures["reason"].str.contains("exit code 3").all()
    assert (ident.candidates["a"] <= 1.5).all() and len(ident.candidates) > 0
    # Per sensor, the falsified runs are those of the NumPy reference over the runs that did not fail.
    g = ident.adaptive.run_predictions
    assert np.isnan(g[failed]).all()
    r = g[~failed] - project.measured
    outside = (r < ident.thresholds.low) | (r > ident.thresholds.high)
    np.testing.assert_array_equal(ident.falsification.per_sensor_falsified, outside.sum(axis=0))
    again = edmf_rs.Project.from_toml(adaptive_project(folder, command_model("fail_high_a"), sd=1.0)).run(
        progress=False, out=out)
    assert again.evaluation["model_evaluations"] == 0  # a failed run is not retried
    assert again.evaluation["failed_instances"] == failed.sum()


def test_a_killed_adaptive_run_resumes_without_rerunning_stored_runs(folder, tmp_path):
    project = adaptive_project(folder, command_model("sleep_high_a"))  # a run with a > 1.5 hangs
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "edmf_rs", "run", str(project), "--out", str(out), "--no-progress"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not list(out.glob("work/instance-*/pid")) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert list(out.glob("work/instance-*/pid")), "no run hung"
    time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=50)
    assert proc.returncode == 130, err
    before = stored(out)
    assert len(before) > 0 and not before["failed"].any()
    # The next run reuses every stored run (the hanging ones now time out: failures, not rerun later).
    project = adaptive_project(folder, command_model("sleep_high_a", timeout=0.5))
    summary = run(project, out)
    assert summary["reused_evaluations"] == len(before)
    assert summary["model_evaluations"] + len(before) == summary["adaptive"]["runs"]
    after = stored(out)
    assert not after.duplicated(["p:a", "p:b"]).any() and len(after) == summary["adaptive"]["runs"]
    pd.testing.assert_frame_equal(after.iloc[:len(before)], before)


SENSOR_NAMES = ("S1", "S2", "S3", "S4")


@pytest.mark.parametrize("theta", [np.zeros((2, 3)), np.zeros(2)])
def test_lookup_names_a_wrong_shape(tmp_path, theta):
    store = KeyedPredictionStore(tmp_path, {"model": "m"}, ("a", "b"), SENSOR_NAMES)
    with pytest.raises(ValueError, match=r"theta: expected an \(n, 2\) array"):
        store.lookup(theta)


def test_failures_reused_from_the_store_count_against_the_failure_policy(folder, tmp_path, capsys):
    # They were counted but never checked: a rerun into the store exited 0 where a fresh folder stops.
    out = tmp_path / "out"
    first = run(adaptive_project(folder, command_model("fail_high_a"), sd=1.0), out)
    assert first["failed_instances"] > 3
    limited = adaptive_project(folder, command_model("fail_high_a", max_failure_rate=0.05), sd=1.0)
    assert cli.main(["run", str(limited), "--out", str(tmp_path / "fresh"), "--no-progress"]) == 1
    assert cli.main(["run", str(limited), "--out", str(out), "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert err.count("more than max_failure_rate = 0.05 allows") == 2
    assert json.loads((out / "summary.json").read_text()) == first  # the stopped rerun wrote no summary
