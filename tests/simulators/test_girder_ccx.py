"""CalculiX itself through the command adapter: the girder-ccx example's
predictions against the analytic girder, and its candidate set."""

import json
import shutil

import numpy as np
import pandas as pd
from edmf_rs import cli
from edmf_rs.examples import girder_ccx

#: CalculiX's B32R beams (expanded to 20-node bricks) include shear deformation,
#: which Euler-Bernoulli leaves out: they deflect a little more (0.5-1.5 % here).
FE_ERROR = 0.025


def test_ccx_is_installed():
    assert shutil.which("ccx"), "CalculiX (ccx) is needed: apt-get install calculix-ccx (.ci/run does it)"


def test_shipped_deck_and_measurements_are_what_the_module_writes(tmp_path):
    girder_ccx.write_files(tmp_path)
    for name in ("girder.inp", "girder-ccx.csv"):
        assert (tmp_path / name).read_text() == (cli.EXAMPLES / name).read_text()


def test_girder_ccx_example_matches_the_analytic_girder(tmp_path):
    out = tmp_path / "out"
    assert cli.main(["run", "--example", "girder-ccx", "--out", str(out), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["instances"], summary["model_evaluations"], summary["failed_instances"]) == (64, 64, 0)
    stored = pd.concat([pd.read_parquet(p) for p in sorted(out.glob("store/*/part-*.parquet"))])
    assert stored["instance"].tolist() == list(range(64))
    theta = stored[["p:E", "p:k_v"]].to_numpy()
    fe = stored[["s:D1", "s:D2", "s:D3"]].to_numpy()
    analytic = girder_ccx.deflections(theta)
    excess = fe / analytic - 1.0
    assert np.all(excess > 0) and np.all(excess < FE_ERROR), excess

    # The candidate set: what the thresholds make of the analytic predictions, except
    # where an instance lies within the FE error of a threshold bound.
    thresholds = pd.read_csv(out / "thresholds.csv")
    residual = analytic - thresholds["measured"].to_numpy()
    low, high = thresholds["threshold_low"].to_numpy(), thresholds["threshold_high"].to_numpy()
    margin = FE_ERROR * np.abs(analytic)
    surely_in = np.all((residual - margin >= low) & (residual + margin <= high), axis=1)
    surely_out = np.any((residual + margin < low) | (residual - margin > high), axis=1)
    candidates = set(pd.read_parquet(out / "candidates.parquet")["instance"])
    assert set(np.flatnonzero(surely_in)) <= candidates
    assert not candidates & set(np.flatnonzero(surely_out))
    assert 0 < len(candidates) < 64
    e = pd.read_parquet(out / "candidates.parquet")["E"]
    assert e.min() < girder_ccx.E_TRUE < e.max()  # the true girder's E lies within the candidates'
