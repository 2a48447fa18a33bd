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
    with pytest.raises(ProjectError, match=r"girder-adaptive.toml: sampling.budget: expected at least n_initial "
                                           r"\+ wave_size = 60 \+ 30 = 90 real runs .*, got 70; raise budget"):
        edmf_rs.Project.from_toml(adaptive_girder(tmp_path, small))


def test_a_budget_too_small_for_the_defaults_is_refused_by_dry_run(tmp_path, capsys):
    """budget = 20 with one parameter: the default n_initial + wave_size is 20 + 10; refused at load
    (exit 2), so --dry-run says so and a run writes no --out folder."""
    (tmp_path / "m.py").write_text("import numpy as np\ndef predict(theta):\n"
                                   "    return np.column_stack([theta[:, 0], theta[:, 0] ** 2])\n")
    (tmp_path / "meas.csv").write_text("sensor,value\nS0,1.5\nS1,2.25\n")
    project = tmp_path / "b.toml"
    project.write_text('[parameters.a]\nlow = 1.0\nhigh = 2.0\n[sampling]\nmethod = "adaptive"\nbudget = 20\n'
                       '[model]\nfunction = "m:predict"\n[measurements]\nfile = "meas.csv"\n[[uncertainty]]\n'
                       'kind = "measurement"\ndistribution = "normal"\nsd = 0.02\n')
    assert cli.main(["run", str(project), "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert "b.toml: sampling.budget: expected at least n_initial + wave_size = 20 + 10 = 30 real runs" in err
    assert "Traceback" not in err
    out = tmp_path / "ob"
    assert cli.main(["run", str(project), "--out", str(out), "--no-progress"]) == 2
    assert not out.exists()
    # budget = 30 holds the initial design and one wave: accepted.
    project.write_text(project.read_text().replace("budget = 20", "budget = 30"))
    assert cli.main(["run", str(project), "--dry-run"]) == 0


def _small_adaptive(tmp_path, sampling: str, n_params: int = 1):
    """A quick adaptive project: a one- or two-parameter model of two or three sensors."""
    if n_params == 1:
        model = "import numpy as np\ndef predict(theta):\n    return np.column_stack([theta[:, 0], theta[:, 0] ** 2])\n"
        meas, params = "sensor,value\nS0,1.5\nS1,2.25\n", "[parameters.a]\nlow = 1.0\nhigh = 2.0\n"
    else:
        model = ("import numpy as np\ndef predict(theta):\n    a, b = theta[:, 0], theta[:, 1]\n"
                 "    return np.column_stack([(a - 0.5)**2 + 0.3*b, b + 0.1*(a - 0.5)**2, a*b])\n")
        meas = "sensor,value\nS0,0.27\nS1,0.609\nS2,0.48\n"
        params = "[parameters.a]\nlow = 0.0\nhigh = 1.0\n[parameters.b]\nlow = 0.0\nhigh = 1.0\n"
    (tmp_path / "m.py").write_text(model)
    (tmp_path / "meas.csv").write_text(meas)
    project = tmp_path / "a.toml"
    project.write_text(params + "[sampling]\n" + sampling + '[model]\nfunction = "m:predict"\n[measurements]\n'
                       'file = "meas.csv"\n[[uncertainty]]\nkind = "measurement"\ndistribution = "normal"\n'
                       "sd = 0.005\n")
    return project


def test_an_adaptive_run_writes_its_report_under_a_non_utf8_locale(tmp_path):
    """report.html is UTF-8 (it holds Greek letters): re-reading it to add the waves must not use the
    locale's encoding (LC_ALL=C: ASCII)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    project = _small_adaptive(tmp_path, 'method = "adaptive"\nbudget = 60\nn_screen = 2048\n')
    env = {k: v for k, v in os.environ.items() if not k.startswith(("LC_", "LANG", "PYTHONUTF8", "PYTHONIOENC"))}
    env.update(LC_ALL="C", PYTHONUTF8="0", PYTHONCOERCECLOCALE="0",
               PYTHONPATH=os.pathsep.join([str(Path(edmf_rs.__file__).parents[1]), env.get("PYTHONPATH", "")]))
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "edmf_rs", "run", str(project), "--out", str(out), "--no-progress"],
                          env=env, capture_output=True, text=True, errors="replace")
    assert done.returncode == 0, done.stderr
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "<h2>Adaptive sampling</h2>" in html and any(ord(ch) > 127 for ch in html)
    assert json.loads((out / "summary.json").read_text(encoding="utf-8"))["adaptive"]["waves"]


@pytest.mark.parametrize("basis", ["pca", "sensors"])
def test_the_report_names_the_emulators_used(tmp_path, basis):
    project = _small_adaptive(tmp_path, f'method = "adaptive"\nbudget = 120\nn_screen = 4096\nbasis = "{basis}"\n',
                              n_params=2)
    ident = edmf_rs.Project.from_toml(project).run(progress=False)
    html = (ident.write(tmp_path / "out") / "report.html").read_text(encoding="utf-8")
    components = sorted({w.components for w in ident.adaptive.waves if w.components is not None})
    if basis == "pca":
        assert components and "one Gaussian process per sensor" not in html
        k = f"{components[0]}" if len(components) == 1 else f"{components[0]} to {components[-1]}"
        assert (f"The emulators (Gaussian processes on the {k} leading principal components of the standardised "
                "outputs of the 3 sensors") in html
    else:
        assert not components and "The emulators (one Gaussian process per sensor)" in html


def test_a_rerun_without_adaptive_sampling_removes_the_waves_figure_it_does_not_write(tmp_path, capsys):
    """Switching a project from adaptive to Sobol' sampling and running into the same folder left the
    first run's adaptive_waves.png beside the second run's report; a foreign folder's file of that name
    (written into with --force) is never removed."""
    project = adaptive_girder(tmp_path, ADAPTIVE.replace("budget = 180", "budget = 100"))
    out = tmp_path / "out"
    assert cli.main(["run", str(project), "--out", str(out), "--no-progress"]) == 0
    assert (out / "adaptive_waves.png").is_file()
    sobol = '[sampling]\nmethod = "sobol"\nn = 256\nseed = 0\n'
    project.write_text(re.sub(r"\[sampling\]\n(?:[^\[\n][^\n]*\n|\n)*", sobol + "\n", project.read_text(), count=1))
    assert cli.main(["run", str(project), "--out", str(out), "--no-progress"]) == 0
    assert not (out / "adaptive_waves.png").exists()
    assert json.loads((out / "summary.json").read_text())["sampling"]["method"] == "sobol"
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "adaptive_waves.png").write_bytes(b"a user's figure")
    assert cli.main(["run", str(project), "--out", str(foreign), "--no-progress", "--force"]) == 0
    assert (foreign / "adaptive_waves.png").read_bytes() == b"a user's figure"
    capsys.readouterr()
