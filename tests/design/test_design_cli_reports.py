"""`edmf-rs design` on small projects: the model's failures reported as `edmf-rs run`
reports them, design.csv read back as CSV, an earlier design's outputs that a rerun
does not write removed (and nothing else), and precomputed predictions or relative
sources that cannot be used named with the file, key and location."""

import csv
import json
import textwrap

import numpy as np
import pytest
from edmf_rs.cli import main

MODEL = textwrap.dedent("""\
    import numpy as np
    def predict(theta, mode="ok"):
        if mode == "runtime":
            raise RuntimeError("solver diverged")
        if mode == "value":
            raise ValueError("bad stiffness")
        if mode == "exit":
            import sys
            sys.exit(3)
        return np.column_stack([theta[:, 0], theta[:, 0] ** 2])
    """)
NOISE = '[[uncertainty]]\nkind = "measurement"\ndistribution = "normal"\nsd = 0.02\n'


def _project(folder, candidates="name,type,location\nD1,deflection,1.0\nD2,deflection,2.0\n", options="",
             k=2, name="d.toml"):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "dmodel.py").write_text(MODEL)
    (folder / "cands.csv").write_text(candidates)
    path = folder / name
    path.write_text('[parameters.a]\nlow = 1.0\nhigh = 2.0\n[sampling]\nmethod = "sobol"\nn = 64\n[model]\n'
                    f'function = "dmodel:predict"\n{options}{NOISE}[design]\ncandidates = "cands.csv"\nk = {k}\n'
                    "n_simulations = 50\n")
    return path


@pytest.mark.parametrize("mode, raised", [
    ("runtime", "raised RuntimeError: solver diverged"),
    ("value", "raised ValueError: bad stiffness"),
    ("exit", "called sys.exit(3)"),
])
def test_a_failing_model_is_reported_as_the_models_failure(tmp_path, capsys, mode, raised):
    project = _project(tmp_path, options=f'options = {{ mode = "{mode}" }}\n')
    out = tmp_path / "out"
    assert main(["design", str(project), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"edmf-rs: error: {project}: model.function = 'dmodel:predict' {raised}, on batch 0 "
                          "(instances 0..63); first failing instance: 0 (a=")
    assert "Traceback" not in err
    assert not out.exists()  # nothing written: the model failed before any output
    assert main(["design", str(project), "--out", str(out), "--traceback"]) == 1
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and 'dmodel.py", line' in err


def test_design_csv_quotes_a_name_holding_a_comma(tmp_path):
    project = _project(tmp_path, candidates='name,type,location\n"D1, left",deflection,1.0\n'
                                            'D2,"strain, ""top""",2.0\n')
    out = tmp_path / "out"
    assert main(["design", str(project), "--out", str(out)]) == 0
    with open(out / "design.csv", newline="", encoding="utf-8") as fh:
        table = list(csv.DictReader(fh))
    sensors = json.loads((out / "design.json").read_text(encoding="utf-8"))["sensors"]
    assert [r["name"] for r in table] == [s["name"] for s in sensors]
    assert {r["name"] for r in table} == {"D1, left", "D2"}
    assert {r["type"] for r in table} == {"deflection", 'strain, "top"'}
    by_name = {r["name"]: r for r in table}
    assert by_name["D1, left"]["location"] == "1.0" and by_name["D2"]["location"] == "2.0"
    assert all(None not in r and len(r) == len(table[0]) for r in table)  # no row has extra fields


def test_a_rerun_removes_the_earlier_designs_outputs_it_does_not_write(tmp_path, capsys):
    project = _project(tmp_path)
    out = tmp_path / "out"
    assert main(["design", str(project), "--out", str(out)]) == 0
    assert (out / "design_locations.png").is_file()
    (out / "notes.txt").write_text("mine")
    # The same project without locations: no plot of locations, so the first design's goes.
    (tmp_path / "cands.csv").write_text("name,type\nD1,deflection\nD2,deflection\n")
    assert main(["design", str(project), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".edmf-rs-run", "design.csv", "design.json",
                                                      "design_curves.png", "notes.txt", "report.html"]
    assert (out / "notes.txt").read_text() == "mine"
    assert "design_locations.png" not in json.loads((out / "design.json").read_text())["outputs"]


def test_a_forced_design_never_removes_another_projects_files(tmp_path, capsys):
    first = _project(tmp_path / "a")
    out = tmp_path / "out"
    assert main(["design", str(first), "--out", str(out)]) == 0
    plot = (out / "design_locations.png").read_bytes()
    # Another project without locations, forced into the folder: the plot is not its own.
    other = _project(tmp_path / "b", candidates="name,type\nD1,deflection\nD2,deflection\n", name="e.toml")
    assert main(["design", str(other), "--out", str(out)]) == 2
    assert main(["design", str(other), "--out", str(out), "--force"]) == 0
    assert (out / "design_locations.png").read_bytes() == plot
    # A project of the same file name in another folder (its design.json looks like an earlier design):
    # the run marker names the first project, so the plot stays.
    twin = _project(tmp_path / "c", candidates="name,type\nD1,deflection\nD2,deflection\n")
    assert main(["design", str(first), "--out", str(out), "--force"]) == 0
    plot = (out / "design_locations.png").read_bytes()
    assert main(["design", str(twin), "--out", str(out)]) == 0
    assert (out / "design_locations.png").read_bytes() == plot
    # A user's folder holding a file of that name, forced: left as it is.
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "design_locations.png").write_bytes(b"my picture")
    assert main(["design", str(other), "--out", str(mine), "--force"]) == 0
    assert (mine / "design_locations.png").read_bytes() == b"my picture"


def _precomputed(folder, g, source=NOISE, suffix=".npy"):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "cands.csv").write_text("name,type\nD1,deflection\nD2,deflection\n")
    if suffix == ".npy":
        np.save(folder / "g.npy", g)
    else:
        lines = ["D1,D2"] + [",".join(repr(float(v)) for v in row) for row in g]
        (folder / "g.csv").write_text("\n".join(lines) + "\n")
    path = folder / "p.toml"
    path.write_text(f'{source}[design]\ncandidates = "cands.csv"\npredictions = "g{suffix}"\nk = 1\n')
    return path


@pytest.mark.parametrize("suffix, value, row", [(".npy", np.nan, "row 7"), (".npy", np.inf, "row 7"),
                                                (".csv", np.nan, "row 7 below the header")])
def test_non_finite_precomputed_predictions_name_the_file_key_and_location(tmp_path, capsys, suffix, value, row):
    g = np.ones((50, 2))
    g[:, 1] = np.arange(50)
    g[7, 1] = value
    project = _precomputed(tmp_path, g, suffix=suffix)
    out = tmp_path / "out"
    assert main(["design", str(project), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.strip() == (f"edmf-rs: error: {project}: design.predictions: g{suffix}: expected finite predictions, "
                           f"got {value} at instance 7 ({row}), location 'D2'; leave out the instances whose model "
                           "run failed, or run them again")
    assert "nan_policy" not in err and not out.exists()


def test_a_relative_source_where_the_mean_prediction_is_zero_is_named(tmp_path, capsys):
    g = np.zeros((50, 2))
    g[:, 1] = np.arange(50)
    relative = ('[[uncertainty]]\nname = "model error"\nkind = "model"\ndistribution = "normal"\nsd = 0.1\n'
                'relative_to = "measured"\n')
    project = _precomputed(tmp_path, g, source=relative)
    assert main(["design", str(project), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"{project}: uncertainty: location 'D1' has only sources relative_to = \"measured\" ('model error')" in err
    assert "mean prediction at the location, which is 0 there" in err and 'relative_to = "absolute"' in err
    # With the sensors' noise as well, D1 has a non-zero uncertainty: the design runs.
    project.write_text(NOISE + project.read_text())
    assert main(["design", str(project), "--out", str(tmp_path / "out")]) == 0
