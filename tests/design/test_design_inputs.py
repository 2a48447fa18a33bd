"""Inputs of a design project that cannot be used are refused with the file,
the key or line and what was expected, never read as something else."""

import re
import shutil
from pathlib import Path

import edmf_rs
import numpy as np
import pytest
from edmf_rs.cli import main
from edmf_rs.design import expected_identifiability, identifiability_curve
from edmf_rs.design.project import read_design_project
from edmf_rs.project import ProjectError
from scipy import stats

PROJECT = Path(__file__).resolve().parents[2] / "python/edmf_rs/examples/design_projects/girder-design.toml"
ROW = "D1-LC1,deflection,1000,3,LC1,mm\n"  # line 3 of the candidates file


@pytest.fixture
def tiny_project(tmp_path):
    """The girder design shrunk to 128 instances and 50 simulations, in its own folder."""
    text = PROJECT.read_text().replace("n = 4096", "n = 128").replace("n_simulations = 1000", "n_simulations = 50")
    (tmp_path / "girder-design.toml").write_text(text)
    shutil.copy(PROJECT.parent / "girder-candidates.csv", tmp_path)
    return tmp_path / "girder-design.toml"


def _edit(file: Path, old: str, new: str) -> None:
    text = file.read_text()
    assert old in text
    file.write_text(text.replace(old, new, 1))


@pytest.mark.parametrize("old, new, message", [
    ("name,type,location,cost,", "name,type,location,cots,",
     r"line 1: unknown column 'cots' \(did you mean 'cost'\?\); expected the columns name, type, location, cost"),
    ("name,type,location,cost,load_case,unit", "name,type,location,cost,load_case,unit,foo",
     r"line 1: unknown column 'foo'; expected the columns"),
    ("name,type,location,cost,load_case,unit", "name,type,location,cost,load_case,cost",
     r"line 1: column 'cost' twice"),
    (ROW, "D1-LC1,deflection,1000,5,3,LC1,mm\n",
     r"line 3: expected 6 fields \(name,type,location,cost,load_case,unit\), got 7; a decimal comma"),
    (ROW, "D1-LC1,deflection,1000,3,LC1\n", r"line 3: expected 6 fields \(name,type,location,cost,load_case,unit\), "
     r"got 5$"),
])
def test_candidates_csv_is_read_strictly(tiny_project, old, new, message):
    _edit(tiny_project.parent / "girder-candidates.csv", old, new)
    with pytest.raises(ProjectError, match=re.escape(str(tiny_project.parent / "girder-candidates.csv")) + ": "
                       + message):
        read_design_project(tiny_project)


def test_candidates_csv_error_exits_2_naming_the_file_and_line(tiny_project, capsys):
    _edit(tiny_project.parent / "girder-candidates.csv", ROW, "D1-LC1,deflection,1000,5,3,LC1,mm\n")
    assert main(["design", str(tiny_project), "--out", str(tiny_project.parent / "out")]) == 2
    assert "girder-candidates.csv: line 3: expected 6 fields" in capsys.readouterr().err
    assert not (tiny_project.parent / "out").exists()


def test_candidates_not_utf8_names_the_project_key_and_line(tiny_project):
    csv = tiny_project.parent / "girder-candidates.csv"
    csv.write_bytes(csv.read_bytes().replace(b"D1-LC1", b"D1-LC\xe9", 1))
    with pytest.raises(ProjectError, match=re.escape(f"{tiny_project}: design.candidates: {csv}: line 3: expected "
                                                     "UTF-8 text, got byte 0xe9; save the file as UTF-8")):
        read_design_project(tiny_project)


def test_candidates_that_is_a_folder_names_the_project_and_key(tiny_project):
    (tiny_project.parent / "cdir").mkdir()
    _edit(tiny_project, 'candidates = "girder-candidates.csv"', 'candidates = "cdir"')
    with pytest.raises(ProjectError, match=re.escape(f"{tiny_project}: design.candidates: expected a regular file, "
                                                     f"'{tiny_project.parent / 'cdir'}' is a directory")):
        read_design_project(tiny_project)


@pytest.mark.parametrize("line, message", [
    ('fixed = ["D1-LC1", "D1-LC1"]', "design.fixed: expected distinct candidate names, got 'D1-LC1' more than once"),
    ('fixed = ["D1-LC1", 3]', "design.fixed: expected a list of candidate names (strings), got ['D1-LC1', 3]"),
    ("tolerance = -1", "design.tolerance: expected a gain in bits >= 0, got -1"),
])
def test_design_keys_are_checked_when_read(tiny_project, line, message):
    _edit(tiny_project, "n_simulations = 50", f"n_simulations = 50\n{line}")
    with pytest.raises(ProjectError, match=re.escape(f"{tiny_project}: {message}")):
        read_design_project(tiny_project)


def test_prediction_files_that_cannot_be_read_are_named(tiny_project):
    folder = tiny_project.parent
    (folder / "g.npy").mkdir()
    _edit(tiny_project, "n_simulations = 50", 'n_simulations = 50\npredictions = "g.npy"')
    with pytest.raises(ProjectError, match=re.escape(f"{tiny_project}: design.predictions: expected a regular file, "
                                                     f"'{folder / 'g.npy'}' is a directory")):
        read_design_project(tiny_project)
    (folder / "g.npy").rmdir()
    np.save(folder / "g.npy", np.zeros((4, 156)))
    (folder / "cols.txt").write_bytes(b"D0.5-LC1\nD1-LC\xe9\n")
    _edit(tiny_project, 'predictions = "g.npy"', 'predictions = "g.npy"\ncolumns = "cols.txt"')
    with pytest.raises(ProjectError, match=re.escape(f"{tiny_project}: design.columns: {folder / 'cols.txt'}: "
                                                     "line 2: expected UTF-8 text, got byte 0xe9")):
        read_design_project(tiny_project)


@pytest.fixture(scope="module")
def small_case():
    g = np.linspace(0, 10, 41)[:, None] * np.ones((1, 2))
    return g, edmf_rs.combine(measurement=[stats.norm(0, 0.5)], n_sensors=2)


@pytest.mark.parametrize("function", [expected_identifiability, identifiability_curve])
def test_a_bad_seed_is_named(small_case, function):
    g, combined = small_case
    what = "seed: expected an integer >= 0, a sequence of them, None or a numpy Generator/SeedSequence, got "
    for seed, error in [(-1, ValueError), ([1, -2], ValueError), ("a", TypeError), (1.5, TypeError),
                        (True, TypeError)]:
        with pytest.raises(error, match=re.escape(what + repr(seed))):
            function(g, combined, [0], n_simulations=5, seed=seed)
    # What NumPy accepts still draws as NumPy does.
    sizes = [function(g, combined, [0, 1], n_simulations=30, seed=s).sizes
             for s in (7, np.int64(7), np.random.default_rng(7), np.random.SeedSequence(7))]
    for s in sizes[1:]:
        np.testing.assert_array_equal(s, sizes[0])


FIXED = 'fixed = ["D1-LC1", "D2-LC1", "SG1-LC1"]'  # cost 3 + 3 + 1 = 7; one strain gauge

# (edit of the project, what it says when read)
BELOW_THE_FIXED_SENSORS = [
    ((("budget = 20.0", "budget = 5.0"), FIXED),
     "design.budget: expected at least 7.0 (the cost of the 3 sensors of design.fixed), got 5.0"),
    ((("k = 12", "k = 2"), FIXED), "design.k: expected at least 3 (the sensors of design.fixed), got 2"),
    ((FIXED, "max_per_type = { strain = 0 }"),
     "design.max_per_type: expected at least 1 for 'strain' (the sensors of type 'strain' in design.fixed), got 0"),
    ((("budget = 20.0", "budget = 0.5"),),
     "design.budget: expected at least 1.0 (the cost of the cheapest candidate location), got 0.5"),
]


def _edit_design(project: Path, edits) -> None:
    """Each edit is a (old, new) replacement or a line added to [design]."""
    for edit in edits:
        if isinstance(edit, tuple):
            _edit(project, *edit)
        else:
            _edit(project, "n_simulations = 50", f"n_simulations = 50\n{edit}")


@pytest.mark.parametrize("edits, message", BELOW_THE_FIXED_SENSORS,
                         ids=["budget-fixed", "k-fixed", "max_per_type-fixed", "budget-cheapest"])
def test_limits_below_the_fixed_sensors_exit_2_naming_file_and_keys_before_computing(tiny_project, monkeypatch, capsys,
                                                                                      edits, message):
    _edit_design(tiny_project, edits)
    with pytest.raises(ProjectError, match="^" + re.escape(f"{tiny_project}: {message}") + "$"):
        read_design_project(tiny_project)

    def no_computation(self):
        raise AssertionError("the project was computed before its limits were checked")

    monkeypatch.setattr("edmf_rs.design.project.DesignProject.predictions", no_computation)
    out = tiny_project.parent / "out"
    assert main(["design", str(tiny_project), "--out", str(out)]) == 2
    assert capsys.readouterr().err == f"edmf-rs: error: {tiny_project}: {message}\n"
    assert not out.exists()


@pytest.mark.parametrize("edit, below, api, api_message", [
    (("budget = 20.0", "budget = 7.0"), ("budget = 7.0", "budget = 6.999"), {"budget": 6.999},
     "budget: expected at least the cost of the fixed sensors (7.0), got 6.999"),
    (("k = 12", "k = 3"), ("k = 3", "k = 2"), {"k": 2}, "k: expected at least the 3 fixed sensors, got 2"),
    ("max_per_type = { strain = 1 }", ("strain = 1", "strain = 0"), {"max_per_type": {"strain": 0}},
     "max_per_type: expected at least the 1 fixed sensors of type 'strain', got 0"),
], ids=["budget", "k", "max_per_type"])
def test_project_refuses_exactly_what_place_sensors_refuses(tiny_project, edit, below, api, api_message):
    """At the limit both the project and place_sensors accept; just below both refuse, each naming its own keys."""
    _edit_design(tiny_project, (FIXED, edit))
    project = read_design_project(tiny_project)
    g = np.random.default_rng(0).normal(size=(16, len(project.candidates)))
    args = dict(k=project.k, fixed=project.fixed, costs=project.costs, types=[c.type for c in project.candidates],
                budget=project.budget, max_per_type=project.max_per_type)
    design = edmf_rs.design.place_sensors(g, np.ones(g.shape[1]), **args)
    assert design.order[:3].tolist() == list(project.fixed)
    with pytest.raises(ValueError, match="^" + re.escape(api_message) + "$"):
        edmf_rs.design.place_sensors(g, np.ones(g.shape[1]), **{**args, **api})
    _edit_design(tiny_project, (below,))
    with pytest.raises(ProjectError, match=re.escape(f"{tiny_project}: design.{next(iter(api))}: expected at least")):
        read_design_project(tiny_project)
