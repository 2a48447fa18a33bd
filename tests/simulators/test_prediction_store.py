"""The prediction store: a second run with the same model and sampling evaluates
nothing, whatever changed in the uncertainties, phi, the correction, the
excluded sensors or the measurements; a killed run resumes exactly."""

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


def run(project, out):
    assert cli.main(["run", str(project), "--out", str(out), "--no-progress"]) == 0
    return json.loads((out / "summary.json").read_text())


@pytest.mark.parametrize("change", [
    dict(sd=0.5),                      # an uncertainty source
    dict(exclude=["S2"]),              # excluded sensors
    dict(edit=("phi = 0.95", "phi = 0.9")),
    dict(edit=("phi = 0.95", 'phi = 0.95\ncorrection = "none"')),
    dict(measurements="S1,1.4"),
])
def test_rerun_after_changing_the_identification_evaluates_nothing(folder, tmp_path, change):
    out = tmp_path / "out"
    first = run(write_project(folder, 'function = "lin_model:predict"', n=128), out)
    assert (first["model_evaluations"], first["reused_evaluations"]) == (128, 0)
    kw = {k: v for k, v in change.items() if k in ("sd", "exclude")}
    project = write_project(folder, 'function = "lin_model:predict"', n=128, **kw)
    if "edit" in change:
        project.write_text(project.read_text().replace(*change["edit"]))
    if "measurements" in change:
        text = (folder / "meas.csv").read_text().splitlines()
        (folder / "meas.csv").write_text("\n".join([text[0], change["measurements"], *text[2:]]) + "\n")
    again = run(project, out)
    assert (again["model_evaluations"], again["reused_evaluations"]) == (0, 128)
    fresh = run(project, tmp_path / "fresh")  # the same change in an empty folder
    assert fresh["model_evaluations"] == 128
    assert again["candidates"] == fresh["candidates"]
    pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "fresh" / "candidates.parquet"))


def test_changing_the_model_or_the_sampling_evaluates_again(folder, tmp_path):
    out = tmp_path / "out"
    run(write_project(folder, 'function = "lin_model:predict"', n=64), out)
    longer = run(write_project(folder, 'function = "lin_model:predict"', n=128), out)
    assert (longer["model_evaluations"], longer["reused_evaluations"]) == (64, 64)  # Sobol' extends
    (folder / "lin_model.py").write_text((folder / "lin_model.py").read_text() + "\n# edited\n")
    edited = run(write_project(folder, 'function = "lin_model:predict"', n=128), out)
    assert (edited["model_evaluations"], edited["reused_evaluations"]) == (128, 0)


def test_reordering_model_sensors_evaluates_again(folder, tmp_path):
    # The store keeps a bare array's columns matched through [model] sensors: read back under
    # another order, they gave the first order's candidates (59 where the right answer was none,
    # on the cantilever example).
    out = tmp_path / "out"
    ordered = 'function = "lin_model:predict"\nsensors = ["S1", "S2", "S3", "S4"]'
    swapped = 'function = "lin_model:predict"\nsensors = ["S2", "S1", "S3", "S4"]'
    first = run(write_project(folder, ordered, n=128), out)
    again = run(write_project(folder, swapped, n=128), out)
    assert (again["model_evaluations"], again["reused_evaluations"]) == (128, 0)
    fresh = run(write_project(folder, swapped, n=128), tmp_path / "fresh")
    assert again["candidates"] == fresh["candidates"] != first["candidates"]
    pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "fresh" / "candidates.parquet"))


def test_a_command_models_store_holds_failures_too(folder, tmp_path):
    out = tmp_path / "out"
    project = write_project(folder, command_model("fail_high_a"), sd=5.0, n=32)
    first = run(project, out)
    assert first["failed_instances"] > 0
    project = write_project(folder, command_model("fail_high_a"), sd=4.0, n=32)
    again = run(project, out)
    assert (again["model_evaluations"], again["reused_evaluations"]) == (0, 32)
    assert again["failed_instances"] == first["failed_instances"]
    (folder / "deck.txt").write_text((folder / "deck.txt").read_text() + "# a changed template\n")
    assert run(project, out)["model_evaluations"] == 32


def test_killed_run_resumes_where_the_store_ends_and_gives_the_uninterrupted_result(folder, tmp_path):
    project = write_project(folder, command_model("sleep=0.05"), n=64)
    whole = run(project, tmp_path / "whole")
    out = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "edmf_rs", "run", str(project), "--out", str(out), "--no-progress"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while not list(out.glob("store/*/part-*.parquet")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert not (out / "summary.json").exists()
    resumed = run(project, out)
    assert 0 < resumed["reused_evaluations"] < 64
    assert resumed["model_evaluations"] == 64 - resumed["reused_evaluations"]
    assert resumed["candidates"] == whole["candidates"]
    pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "whole" / "candidates.parquet"))
    assert (pd.read_csv(out / "thresholds.csv").equals(pd.read_csv(tmp_path / "whole" / "thresholds.csv")))
