"""The design project file and `edmf-rs design` on the girder example."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from edmf_rs.cli import main
from edmf_rs.design import interval_widths
from edmf_rs.design import reference as ref
from edmf_rs.design.project import read_design_project

PROJECT = Path(__file__).resolve().parents[2] / "python/edmf_rs/examples/design_projects/girder-design.toml"


@pytest.fixture(scope="module")
def small_project(tmp_path_factory):
    """The girder design with fewer instances and simulations (same candidates and sources)."""
    folder = tmp_path_factory.mktemp("design")
    text = PROJECT.read_text().replace("n = 4096", "n = 512").replace("n_simulations = 1000", "n_simulations = 200")
    (folder / "girder-design.toml").write_text(text)
    shutil.copy(PROJECT.parent / "girder-candidates.csv", folder)
    return folder / "girder-design.toml"


def test_girder_design_cli_writes_every_output(small_project, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["design", str(small_project), "--out", str(out)]) == 0
    doc = json.loads((out / "design.json").read_text())
    sensors = doc["sensors"]
    assert doc["n_candidates"] == 156 and doc["n_instances"] == 512
    # The chosen order is the reference greedy placement on the same predictions and widths.
    project = read_design_project(small_project)
    g = project.predictions()
    widths = interval_widths(project.combined_uncertainty(g), project.k, project.phi)
    order, h = ref.place_sensors(g, widths, project.k, costs=project.costs, budget=project.budget)
    assert [s["index"] for s in sensors] == order
    np.testing.assert_allclose([s["joint_entropy"] for s in sensors], h, atol=1e-9)
    assert sensors[-1]["cumulative_cost"] <= 20.0
    assert all(0 <= s["mean_candidates"] <= 512 for s in sensors)
    assert {s["type"] for s in sensors} <= {"deflection", "strain"}
    csv_lines = (out / "design.csv").read_text().splitlines()
    assert len(csv_lines) == len(sensors) + 1 and csv_lines[1].split(",")[2] == sensors[0]["name"]
    for png in ("design_curves.png", "design_locations.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (out / "report.html").read_text()
    assert sensors[0]["name"] in html and "design_curves.png" in html
    assert not list(out.glob(".*.tmp"))  # atomic writes leave no temporary files


def test_candidates_that_the_model_does_not_predict_are_named(small_project, tmp_path, capsys):
    folder = small_project.parent
    bad = folder / "bad-candidates.csv"
    bad.write_text((folder / "girder-candidates.csv").read_text() + "X99-LC1,strain,20000,1,LC1,microstrain\n")
    toml = folder / "bad.toml"
    toml.write_text(small_project.read_text().replace("girder-candidates.csv", "bad-candidates.csv"))
    assert main(["design", str(toml), "--out", str(tmp_path / "o")]) == 2
    assert "X99-LC1" in capsys.readouterr().err


def test_bad_design_table_names_the_key(small_project, tmp_path, capsys):
    toml = small_project.parent / "bad-k.toml"
    toml.write_text(small_project.read_text().replace("k = 12", "k = 500"))
    assert main(["design", str(toml), "--out", str(tmp_path / "o")]) == 2
    assert "design.k" in capsys.readouterr().err


def test_girder_candidates_at_the_test_sensors_equal_the_identification_model():
    from edmf_rs.examples import girder, girder_design

    theta = np.array([[36e3, 3e11, 2e5], [25e3, 1e10, 1e3], [48e3, 1e14, 1e7]])
    g = girder_design.predict(theta)
    expected = girder.predict(theta)
    for j, (_, kind, x, _) in enumerate(girder.SENSORS):
        name = ("D" if kind == "deflection" else "SG") + f"{x / 1000:g}-LC1"
        np.testing.assert_allclose(g[name].to_numpy(), expected[:, j], rtol=1e-10)
    # The second load case is the first one mirrored: the girder's model is not
    # symmetric (rotational spring on the left only), so they differ.
    assert not np.allclose(g["D5-LC2"], g["D15-LC1"])
    # Between nodes the Hermite deflection lies between its neighbours' here (rising towards the truck).
    assert np.all((g["D3.5-LC1"] - g["D3-LC1"]) * (g["D4-LC1"] - g["D3.5-LC1"]) >= 0)


def _precomputed_project(small_project, folder, key_lines):
    """The small girder design with [design] reading precomputed predictions (no model, parameters, sampling)."""
    text = small_project.read_text()
    head, design_table = text.split("[design]")
    head = head.split("[parameters.E]")[0] + "[[uncertainty]]" + head.split("[[uncertainty]]", 1)[1]
    toml = folder / "pre.toml"
    toml.write_text(head + "[design]" + design_table + "\n".join(key_lines) + "\n")
    shutil.copy(small_project.parent / "girder-candidates.csv", folder)
    return toml


def test_precomputed_npy_predictions_give_the_model_design(small_project, tmp_path):
    project = read_design_project(small_project)
    g = project.predictions()
    np.save(tmp_path / "g.npy", g.astype(np.float32))
    toml = _precomputed_project(small_project, tmp_path, ['predictions = "g.npy"'])
    pre = read_design_project(toml)
    assert pre.model_function is None and pre.sampling is None
    mm = pre.predictions()
    assert isinstance(mm, np.memmap) and mm.dtype == np.float32
    assert main(["design", str(toml), "--out", str(tmp_path / "out")]) == 0
    doc = json.loads((tmp_path / "out" / "design.json").read_text())
    g32 = g.astype(np.float32)
    widths = interval_widths(pre.combined_uncertainty(g32), pre.k, pre.phi)
    order, h = ref.place_sensors(g32, widths, pre.k, costs=pre.costs, budget=pre.budget)
    assert [s["index"] for s in doc["sensors"]] == order
    # Both load cases are candidates: 78 locations each.
    assert sorted({c.load_case for c in pre.candidates}) == ["LC1", "LC2"]
    assert sum(c.load_case == "LC2" for c in pre.candidates) == 78


def test_npy_memory_map_reaches_rust_without_a_copy(small_project, tmp_path):
    import tracemalloc

    from edmf_rs.design import _checks, place_sensors

    g = np.random.default_rng(0).normal(size=(5_000, 156)).astype(np.float32)  # 3.1 MB
    np.save(tmp_path / "g.npy", g)
    pre = read_design_project(_precomputed_project(small_project, tmp_path, ['predictions = "g.npy"']))
    mm = pre.predictions()
    assert isinstance(mm, np.memmap) and np.shares_memory(mm, _checks.predictions_array(mm))
    assert _checks.predictions_array(mm) is mm
    tracemalloc.start()
    d = place_sensors(mm, np.full(156, 0.5), 5)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < mm.nbytes / 20  # no NumPy copy of the predictions
    assert d.order.tolist() == ref.place_sensors(g[:, :], np.full(156, 0.5), 5)[0]


def test_csv_predictions_are_matched_by_name_in_any_order(small_project, tmp_path):
    project = read_design_project(small_project)
    g = project.predictions()
    names = [c.name for c in project.candidates]
    perm = np.random.default_rng(1).permutation(len(names))
    header = ",".join(names[j] for j in perm)
    np.savetxt(tmp_path / "g.csv", g[:, perm], delimiter=",", header=header, comments="")
    pre = read_design_project(_precomputed_project(small_project, tmp_path, ['predictions = "g.csv"']))
    assert [c.name for c in pre.candidates] == [names[j] for j in perm]
    np.testing.assert_array_equal(pre.predictions(), g[:, perm])


def test_npy_columns_that_are_not_the_candidates_are_named(small_project, tmp_path, capsys):
    project = read_design_project(small_project)
    names = [c.name for c in project.candidates]
    np.save(tmp_path / "g.npy", np.zeros((10, len(names))))
    (tmp_path / "cols.txt").write_text("\n".join(["ZZ-LC9"] + names[1:]) + "\n")
    toml = _precomputed_project(small_project, tmp_path, ['predictions = "g.npy"', 'columns = "cols.txt"'])
    assert main(["design", str(toml), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert names[0] in err and "ZZ-LC9" in err
    np.save(tmp_path / "g.npy", np.zeros((10, 3)))
    toml = _precomputed_project(small_project, tmp_path, ['predictions = "g.npy"'])
    assert main(["design", str(toml), "--out", str(tmp_path / "o")]) == 2
    assert "design.predictions" in capsys.readouterr().err


def test_max_per_type_in_the_project_file(small_project, tmp_path, capsys):
    toml = small_project.parent / "quota.toml"
    toml.write_text(small_project.read_text().replace("k = 12", "k = 12\nmax_per_type = { deflection = 1 }"))
    out = tmp_path / "out"
    assert main(["design", str(toml), "--out", str(out)]) == 0
    sensors = json.loads((out / "design.json").read_text())["sensors"]
    assert sum(s["type"] == "deflection" for s in sensors) <= 1
    project = read_design_project(toml)
    g = project.predictions()
    widths = interval_widths(project.combined_uncertainty(g), project.k, project.phi)
    types = [c.type for c in project.candidates]
    order, _ = ref.place_sensors(g, widths, project.k, costs=project.costs, budget=project.budget, types=types,
                                 max_per_type={"deflection": 1})
    assert [s["index"] for s in sensors] == order
    bad = small_project.parent / "quota-bad.toml"
    bad.write_text(small_project.read_text().replace("k = 12", "k = 12\nmax_per_type = { rotation = 1 }"))
    assert main(["design", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "design.max_per_type" in capsys.readouterr().err


def test_design_project_files_are_read_like_identification_projects(tmp_path):
    # One reader for both kinds of project file: the same messages for a missing file, a directory, bad TOML.
    from edmf_rs.project import ProjectError

    with pytest.raises(ProjectError, match=r"nowhere\.toml: no such project file \(looked in "):
        read_design_project(tmp_path / "nowhere.toml")
    with pytest.raises(ProjectError, match="expected a project file \\(TOML\\), got a directory"):
        read_design_project(tmp_path)
    (tmp_path / "bad.toml").write_text("[identification]\nphi = = 0.9\n")
    with pytest.raises(ProjectError, match=r"bad\.toml: invalid TOML"):
        read_design_project(tmp_path / "bad.toml")
    (tmp_path / "phi.toml").write_text("[identification]\nphi = 1.0\n")
    with pytest.raises(ProjectError, match=r"identification\.phi: expected a probability in \(0, 1\), got 1\.0"):
        read_design_project(tmp_path / "phi.toml")
