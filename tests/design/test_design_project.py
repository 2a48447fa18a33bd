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
