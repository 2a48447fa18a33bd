"""OpenSeesPy through a Python function model in a pool of 2 spawned processes:
the girder-opensees example gives the NumPy girder's predictions and candidates."""

import json
import shutil

import numpy as np
import pandas as pd
from edmf_rs import cli
from edmf_rs.examples import girder, girder_opensees


def test_opensees_girder_predicts_as_the_numpy_girder():
    rng = np.random.default_rng(3)
    theta = np.column_stack([rng.uniform(20e3, 50e3, 20), 10 ** rng.uniform(10, 14, 20), 10 ** rng.uniform(3, 7, 20)])
    np.testing.assert_allclose(girder_opensees.predict(theta), girder.predict(theta), rtol=1e-8, atol=1e-8)


def test_girder_opensees_example_with_two_workers_gives_the_numpy_girders_candidates(tmp_path):
    shutil.copy(cli.EXAMPLES / "girder.csv", tmp_path)
    text = (cli.EXAMPLES / "girder-opensees.toml").read_text().replace("n = 4096 ", "n = 1024 ")
    assert "n = 1024" in text and "workers = 2" in text
    (tmp_path / "ops.toml").write_text(text)
    (tmp_path / "np.toml").write_text(text.replace("girder_opensees:predict", "girder:predict")
                                      .replace("workers = 2", "workers = 1"))
    for name in ("ops", "np"):
        assert cli.main(["run", str(tmp_path / f"{name}.toml"), "--out", str(tmp_path / name), "--no-progress"]) == 0
    summary = json.loads((tmp_path / "ops" / "summary.json").read_text())
    assert summary["model_evaluations"] == 1024 and summary["candidates"] > 0
    ops, ref = (pd.read_parquet(tmp_path / name / "candidates.parquet") for name in ("ops", "np"))
    assert ops["instance"].tolist() == ref["instance"].tolist()
    np.testing.assert_allclose(ops.to_numpy(), ref.to_numpy(), rtol=1e-8)
