"""summary.json says how each sensor's threshold bounds were found, as thresholds.csv
and the console do: exact, numerical convolution of the sources, or Monte Carlo.

Before this test it said "monte_carlo" for every project with a non-normal source,
even where no bound came from samples (the girder: D1-D3 convolution, SG1-SG7 exact).
"""

import json

import pandas as pd
from edmf_rs.project import Project

from _projects import LINEAR_CSV, LINEAR_MODEL, project_text, write_project

NOISE = {"name": "noise", "kind": "measurement", "distribution": "normal", "sd": 0.05}


def run(tmp_path, *sources):
    text = project_text(identification={"name": "methods", "n_samples": 20_000},
                        parameters={"a": (0.0, 2.0), "b": (0.0, 2.0)},
                        sampling={"method": "grid", "points": {"a": 5, "b": 5}},
                        model={"function": "linmodel:predict"}, measurements={"file": "meas.csv"},
                        uncertainty=(NOISE, *sources))
    path = write_project(tmp_path / "project", text, modules={"linmodel": LINEAR_MODEL}, csv=LINEAR_CSV)
    out = tmp_path / "out"
    ident = Project.from_toml(path).run(progress=False)
    ident.write(out)
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    table = pd.read_csv(out / "thresholds.csv")
    return ident, summary, dict(zip(table["sensor"], table["method"]))


def test_a_uniform_source_on_two_sensors_is_convolution_there_and_exact_elsewhere(tmp_path):
    uniform = {"name": "simplification", "kind": "model", "distribution": "uniform", "low": -0.1, "high": 0.3,
               "sensors": ["S1", "S2"]}
    ident, summary, csv = run(tmp_path, uniform)
    assert csv == {"S1": "convolution", "S2": "convolution", "S3": "exact", "S4": "exact"}
    assert summary["identification"]["combined_uncertainty"] == {"exact": ["S3", "S4"],
                                                                 "convolution": ["S1", "S2"]}
    assert summary["identification"]["monte_carlo_confidence"] is None  # no bound from samples
    assert summary["schema"] == "edmf_rs.project-summary/3"
    first = ident.summary().splitlines()[0]
    assert first.endswith("combined uncertainty exact at 2 sensors, numerical convolution of the sources at 2 sensors")
    report = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert ("<td class='l'>exact (every source normal, or one source) at S3, S4; numerical convolution of the sources "
            "(error &lt; 1e-4 of the width) at S1, S2</td>") in report


def test_a_source_that_cannot_be_convolved_is_monte_carlo_at_its_sensor_only(tmp_path):
    cauchy = {"name": "outliers", "kind": "model", "distribution": "cauchy", "params": {"scale": 0.01},
              "sensors": ["S4"]}
    uniform = {"name": "simplification", "kind": "model", "distribution": "uniform", "low": -0.1, "high": 0.3,
               "sensors": ["S1"]}
    ident, summary, csv = run(tmp_path, cauchy, uniform)
    assert csv["S1"] == "convolution" and csv["S2"] == csv["S3"] == "exact"
    assert csv["S4"] not in ("exact", "convolution")  # the Monte Carlo estimator's name
    assert summary["identification"]["combined_uncertainty"] == {"exact": ["S2", "S3"], "convolution": ["S1"],
                                                                 "monte_carlo": ["S4"]}
    assert summary["identification"]["monte_carlo_samples"] == 20_000
    assert summary["identification"]["monte_carlo_confidence"] == 0.975


def test_every_source_normal_is_exact_everywhere(tmp_path):
    ident, summary, csv = run(tmp_path)
    assert set(csv.values()) == {"exact"}
    assert summary["identification"]["combined_uncertainty"] == {"exact": ["S1", "S2", "S3", "S4"]}
    assert summary["identification"]["monte_carlo_samples"] is None
    assert ident.summary().splitlines()[0].endswith("combined uncertainty exact (normal)")
    report = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert "<td class='l'>exact (every source normal, or one source)</td>" in report
