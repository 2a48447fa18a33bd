"""`edmf-rs falsify STORE --project P.toml` (issue 14, part 4): the falsification
again from a prediction store equals a fresh `run` of the same project, with 0
model evaluations; a path that is not a store, a store of another model or
sampling, and a project with sensors the store lacks exit with status 2."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from edmf_rs import cli

from _projects import LINEAR_CSV, LINEAR_MODEL, project_text, write_project

CSV4 = LINEAR_CSV
CSV3 = "sensor,type,value\nS1,deflection,1.3\nS2,deflection,1.8\nS3,strain,2.0\n"


def project(folder: Path, *, sd: float = 0.4, n: int = 512, high: float = 2.0, function: str = "predict",
            options: dict | None = None, csv: str = CSV4, exclude: tuple = (), name: str = "lin.toml") -> Path:
    text = project_text(
        identification={"name": "linear", "phi": 0.95}, parameters={"a": (0.0, high), "b": (0.0, 2.0)},
        sampling={"method": "sobol", "n": n, "seed": 3},
        model={"function": f"lin_model:{function}", "batch_size": 100, **({"options": options} if options else {})},
        measurements={"file": "meas.csv", **({"exclude": list(exclude)} if exclude else {})},
        uncertainty=[{"name": "model", "kind": "model", "distribution": "normal", "mean": 0.1, "sd": 0.3},
                     {"name": "noise", "kind": "measurement", "distribution": "uniform", "low": -sd, "high": sd}])
    return write_project(folder, text, modules={"lin_model": LINEAR_MODEL}, csv=csv, name=name)


def run(*args) -> int:
    return cli.main([*args, "--no-progress"])


def summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def same_outputs(a: Path, b: Path) -> None:
    pd.testing.assert_frame_equal(pd.read_parquet(a / "candidates.parquet"), pd.read_parquet(b / "candidates.parquet"))
    assert (a / "thresholds.csv").read_text() == (b / "thresholds.csv").read_text()
    sa, sb = summary(a), summary(b)
    for s in (sa, sb):
        for key in ("elapsed_seconds", "model_evaluations", "reused_evaluations"):
            s.pop(key)
    assert sa == sb


@pytest.mark.parametrize("change", ["sd", "exclude"])
def test_falsify_from_the_store_equals_a_fresh_run_with_zero_evaluations(tmp_path, change):
    first = project(tmp_path / "p")
    assert run("run", str(first), "--out", str(tmp_path / "run1")) == 0
    assert summary(tmp_path / "run1")["model_evaluations"] == 512
    # another uncertainty source or an excluded sensor: a fresh run of the changed project ...
    changed = {"sd": {"sd": 0.25}, "exclude": {"exclude": ["S3"]}}[change]
    project(tmp_path / "p", **changed)
    assert run("run", str(first), "--out", str(tmp_path / "fresh")) == 0
    # ... equals the falsification from the first run's store, which evaluates nothing
    assert run("falsify", str(tmp_path / "run1"), "--project", str(first), "--out", str(tmp_path / "re")) == 0
    s = summary(tmp_path / "re")
    assert s["model_evaluations"] == 0 and s["reused_evaluations"] == 512
    assert summary(tmp_path / "run1")["candidates"] != s["candidates"]  # the change mattered
    same_outputs(tmp_path / "fresh", tmp_path / "re")
    assert {p.name for p in (tmp_path / "re").glob("*.png")} == {p.name for p in (tmp_path / "fresh").glob("*.png")}


def test_the_store_may_be_named_as_out_store_or_its_key_folder(tmp_path):
    p = project(tmp_path / "p")
    assert run("run", str(p), "--out", str(tmp_path / "run1")) == 0
    key = next((tmp_path / "run1" / "store").iterdir())
    for k, store in enumerate([tmp_path / "run1" / "store", key]):
        assert run("falsify", str(store), "--project", str(p), "--out", str(tmp_path / f"re{k}")) == 0
        same_outputs(tmp_path / "run1", tmp_path / f"re{k}")


def refused(capsys, *args) -> str:
    capsys.readouterr()
    assert run(*args) == 2
    return capsys.readouterr().err


def test_bad_stores_exit_2_naming_the_file_and_what_was_expected(tmp_path, capsys):
    p = project(tmp_path / "p")
    assert run("run", str(p), "--out", str(tmp_path / "run1")) == 0
    out = ["--out", str(tmp_path / "re")]

    err = refused(capsys, "falsify", str(tmp_path / "nowhere"), "--project", str(p), *out)
    assert "nowhere: no such prediction store" in err

    (tmp_path / "empty").mkdir()
    err = refused(capsys, "falsify", str(tmp_path / "empty"), "--project", str(p), *out)
    assert "empty: not a prediction store: expected a folder holding manifest.json" in err

    other = project(tmp_path / "q", options={"scale": 2.0})
    err = refused(capsys, "falsify", str(tmp_path / "run1"), "--project", str(other), *out)
    assert "holds another model" in err and "lin_model:predict" in err and "expected the model of lin.toml" in err

    wider = project(tmp_path / "w", high=3.0)
    err = refused(capsys, "falsify", str(tmp_path / "run1"), "--project", str(wider), *out)
    assert "holds other parameters" in err and "3.0" in err and "2.0" in err

    longer = project(tmp_path / "l", n=1024)
    err = refused(capsys, "falsify", str(tmp_path / "run1"), "--project", str(longer), *out)
    assert "holds instances 0..511 (512), lin.toml has 1,024" in err

    (tmp_path / "run1" / "store" / next((tmp_path / "run1" / "store").iterdir()).name / "manifest.json").write_text("{")
    err = refused(capsys, "falsify", str(tmp_path / "run1"), "--project", str(p), *out)
    assert "manifest.json: expected a prediction store's manifest (JSON)" in err
    assert not (tmp_path / "re").exists()  # nothing written


def test_a_project_with_sensors_the_store_lacks_exits_2(tmp_path, capsys):
    three = project(tmp_path / "three", function="three_columns", csv=CSV3)
    assert run("run", str(three), "--out", str(tmp_path / "run3")) == 0
    four = project(tmp_path / "four")
    err = refused(capsys, "falsify", str(tmp_path / "run3"), "--project", str(four), "--out", str(tmp_path / "re"))
    assert "holds no predictions for sensor(s) S4 of lin.toml; it has S1, S2, S3" in err


def test_a_precomputed_project_has_no_store(tmp_path, capsys):
    p = project(tmp_path / "p")
    assert run("run", str(p), "--out", str(tmp_path / "run1")) == 0
    theta = np.array([[1.0, 1.0], [0.5, 1.5]])
    np.save(tmp_path / "p" / "theta.npy", theta)
    np.save(tmp_path / "p" / "g.npy", theta @ np.array([[1.0, 2.0, 0.5, -1.0], [0.3, -0.2, 1.5, 0.8]]))
    text = p.read_text().replace('[sampling]\nmethod = "sobol"\nn = 512\nseed = 3\n', "").replace(
        'function = "lin_model:predict"', 'predictions = "g.npy"\nparameters = "theta.npy"')
    (tmp_path / "p" / "pre.toml").write_text(text)
    err = refused(capsys, "falsify", str(tmp_path / "run1"), "--project", str(tmp_path / "p" / "pre.toml"),
                  "--out", str(tmp_path / "re"))
    assert "pre.toml: model: precomputed predictions have no prediction store" in err
