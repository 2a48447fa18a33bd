"""[sampling] method = "adaptive" in a project file (issue 16, step 4)."""

import json
import re
import shutil

import edmf_rs
import numpy as np
import pytest
from edmf_rs import cli, reference
from edmf_rs.project.schema import ProjectError

ADAPTIVE = """[sampling]
method = "adaptive"
budget = 180
n_initial = 60
wave_size = 30
n_screen = 8192
seed = 0
"""


def adaptive_girder(tmp_path, sampling=ADAPTIVE):
    src = (cli.EXAMPLES / "girder-sg5-excluded.toml").read_text()
    text = re.sub(r"\[sampling\]\n(?:[^\[\n][^\n]*\n|\n)*", sampling + "\n", src, count=1)
    shutil.copy(cli.EXAMPLES / "girder.csv", tmp_path / "girder.csv")
    path = tmp_path / "girder-adaptive.toml"
    path.write_text(text)
    return path


def test_an_adaptive_project_runs_and_records_its_waves(tmp_path):
    project = edmf_rs.Project.from_toml(adaptive_girder(tmp_path))
    assert project.sampling.method == "adaptive" and project.sampling.budget == 180
    ident = project.run(progress=False)
    r = ident.adaptive
    assert r.n_runs <= 180 and ident.falsification.n_instances == r.n_runs
    # No false candidate: the NumPy reference of Eq. 8 on the real outputs.
    ref = reference.falsify(r.run_predictions, project.measured, ident.thresholds)
    np.testing.assert_array_equal(ident.falsification.candidate_indices, ref.candidate_indices)
    assert ident.falsification.n_candidates > 0 and len(ident.prognoses) == 1
    out = ident.write(tmp_path / "out")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sampling"]["method"] == "adaptive"
    waves = summary["adaptive"]["waves"]
    assert [w["runs"] for w in waves] == [w.n_runs for w in r.waves] and sum(w["runs"] for w in waves) == r.n_runs
    assert waves[0]["kept_fraction"] > 0 and waves[-1]["kind"] == "final"
    html = (out / "report.html").read_text()
    assert "<h2>Adaptive sampling</h2>" in html and "runs of wave" not in html  # the legend is in the PNG
    assert (out / "adaptive_waves.png").stat().st_size > 1000


def test_bad_adaptive_options_name_the_key(tmp_path):
    bad = ADAPTIVE.replace("n_initial = 60", "n_initial = 2")
    with pytest.raises(ProjectError, match=r"sampling.n_initial: expected an integer >= 4, got 2"):
        edmf_rs.Project.from_toml(adaptive_girder(tmp_path, bad))
    bad = ADAPTIVE + "n = 100\n"
    with pytest.raises(ProjectError, match=r"unknown key 'sampling.n'"):
        edmf_rs.Project.from_toml(adaptive_girder(tmp_path, bad))
    small = ADAPTIVE.replace("budget = 180", "budget = 70")
    project = edmf_rs.Project.from_toml(adaptive_girder(tmp_path, small))
    with pytest.raises(ProjectError, match=r"sampling: budget: expected at least n_initial \+ wave_size"):
        project.run(progress=False)
