"""Project inputs read strictly and safely (issue 12, part 9): measurements
fields, decimal commas, encodings, FIFOs, phi's range, read-only theta,
precomputed predictions streamed in chunks."""

import os

import edmf_rs
import numpy as np
import pandas as pd
import pytest
from edmf_rs import cli
from edmf_rs.project import Project, ProjectError
from edmf_rs.project import precomputed as precomputed_module
from scipy import stats

from _projects import project_text, write_project

MODEL = "def g(theta):\n    return theta[:, :2] * [1.0, 2.0]\n"
PROJECT = project_text(identification={"phi": 0.95}, parameters={"a": (0.0, 1.0), "b": (0.0, 1.0)},
                       sampling={"method": "grid", "points": {"a": 11, "b": 11}}, model={"function": "m:g"},
                       measurements={"file": "meas.csv"},
                       uncertainty=[{"name": "noise", "kind": "measurement", "distribution": "normal", "sd": 0.05}])


def write(tmp_path, csv: str | bytes, toml: str = PROJECT):
    return write_project(tmp_path, toml, modules={"m": MODEL}, csv=csv)


def test_a_decimal_comma_is_refused_with_the_line(tmp_path, capsys):
    path = write(tmp_path, "sensor,value\nS1,0.5\nS2,0,167689\n")
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "meas.csv: line 3: expected 2 fields (sensor,value), got 3; a decimal comma (as in 0,167689)?" in err
    assert 'set decimal = "," under [measurements]' in err
    quoted = write(tmp_path, 'sensor,value\nS1,0.5\nS2,"0,167689"\n')
    with pytest.raises(ProjectError, match=r"line 3: value: expected a number, got '0,167689'; a decimal comma"):
        Project.from_toml(quoted)


def test_decimal_comma_option_reads_the_same_values(tmp_path):
    dot = Project.from_toml(write(tmp_path / "dot", "sensor,value,location\nS1,0.5,1.25\nS2,0.167689,2\n"))
    comma = Project.from_toml(write(tmp_path / "comma", "sensor;value;location\nS1;0,5;1,25\nS2;0,167689;2\n",
                                    PROJECT.replace('file = "meas.csv"', 'file = "meas.csv"\ndecimal = ","')))
    np.testing.assert_array_equal(comma.measured, dot.measured)
    assert [s.location for s in comma.sensors] == [1.25, 2.0]
    a, b = dot.run(progress=False), comma.run(progress=False)
    np.testing.assert_array_equal(a.falsification.candidate_indices, b.falsification.candidate_indices)


@pytest.mark.parametrize("csv, fragment", [
    ("sensor,value\nS1,0.5,x\nS2,1\n", "line 2: expected 2 fields (sensor,value), got 3"),
    ("sensor,value,comment\nS1,0.5,ok\nS2,1,ok\n", "line 1: unknown column 'comment'"),
    ("sensor,value,value\nS1,0.5,1\n", "line 1: column 'value' twice"),
    ("sensor,value,unit\nS1,0.5\nS2,1,mm\n", "line 2: expected 3 fields (sensor,value,unit), got 2"),
])
def test_no_field_is_dropped_silently(tmp_path, csv, fragment):
    with pytest.raises(ProjectError, match="meas.csv: " + fragment.replace("(", r"\(").replace(")", r"\)")):
        Project.from_toml(write(tmp_path, csv))


def test_an_encoding_error_names_the_file_and_line(tmp_path):
    latin = "sensor,value\nS1,0.5\nDé2,1.0\n".encode("latin-1")
    with pytest.raises(ProjectError) as err:
        Project.from_toml(write(tmp_path, latin))
    assert str(err.value).startswith(f"{tmp_path / 'meas.csv'}: line 3: expected utf-8 text, got byte 0xe9")
    project = Project.from_toml(write(tmp_path, latin, PROJECT.replace('file = "meas.csv"',
                                                                       'file = "meas.csv"\nencoding = "latin-1"')))
    assert project.sensor_names == ("S1", "Dé2")
    with pytest.raises(ProjectError, match="measurements.encoding"):
        Project.from_toml(write(tmp_path, latin, PROJECT.replace('file = "meas.csv"',
                                                                 'file = "meas.csv"\nencoding = "klingon"')))


@pytest.mark.parametrize("which", ["measurements", "project", "predictions"])
def test_fifos_are_refused_without_blocking(tmp_path, which):
    path = write(tmp_path, "sensor,value\nS1,0.5\nS2,1\n")
    if which == "measurements":
        (tmp_path / "meas.csv").unlink()
        os.mkfifo(tmp_path / "meas.csv")
        expected = r"measurements\.file: expected a regular file, .* is a FIFO"
    elif which == "project":
        path = tmp_path / "fifo.toml"
        os.mkfifo(path)
        expected = "expected a project file .* FIFO"
    else:
        np.save(tmp_path / "theta.npy", np.zeros((3, 2)))
        os.mkfifo(tmp_path / "g.npy")
        path.write_text(PROJECT.replace('[sampling]\nmethod = "grid"\npoints = { a = 11, b = 11 }\n', "")
                        .replace('function = "m:g"', 'predictions = "g.npy"\nparameters = "theta.npy"'))
        expected = r"model\.predictions: expected a regular file, .* is a FIFO"
    with pytest.raises(ProjectError, match=expected):
        Project.from_toml(path)


@pytest.mark.parametrize("phi", ["1e-300", "0.3", "1.0"])
def test_phi_outside_a_sane_range_is_refused(tmp_path, phi):
    with pytest.raises(ProjectError, match=r"identification\.phi: expected a target identification probability "
                                           r"between 0\.5 and 0\.999999999"):
        Project.from_toml(write(tmp_path, "sensor,value\nS1,0.5\nS2,1\n", PROJECT.replace("phi = 0.95", f"phi = {phi}")))


def test_a_model_cannot_edit_the_callers_theta():
    theta = np.random.default_rng(0).uniform(0, 1, (50, 2))
    before = theta.copy()
    combined = edmf_rs.combine(model=[stats.norm(0, 0.3)], measurement=[stats.norm(0, 0.1)], n_sensors=2)
    thresholds = edmf_rs.threshold_bounds(combined, 0.95)

    def edits(t):
        t[:, 0] = 0.0
        return t

    with pytest.raises(ValueError, match="read-only"):
        edmf_rs.falsify_model(edits, theta, [0.5, 0.5], thresholds, progress=False)
    np.testing.assert_array_equal(theta, before)


def test_precomputed_npy_is_streamed_in_batches(tmp_path, monkeypatch):
    rng = np.random.default_rng(1)
    theta = rng.uniform(0, 1, (1000, 2))
    np.save(tmp_path / "theta.npy", theta)
    np.save(tmp_path / "g.npy", np.column_stack([2.0 * theta[:, 1], theta[:, 0], np.zeros(1000)]))  # S2, S1, T
    toml = PROJECT.replace('[sampling]\nmethod = "grid"\npoints = { a = 11, b = 11 }\n', "").replace(
        'function = "m:g"', 'predictions = "g.npy"\nparameters = "theta.npy"\nsensors = ["S2", "S1", "T"]\n'
                            'batch_size = 64')
    path = write(tmp_path, "sensor,value\nS1,0.5\nS2,1.0\n", toml)
    expected = np.flatnonzero(np.all(np.abs(theta * [1.0, 2.0] - [0.5, 1.0]) <= 0.05 * stats.norm.ppf(
        1 - (1 - 0.95 ** 0.5) / 2), axis=1))
    assert expected.size > 0
    sizes = []
    real = precomputed_module._iter_npy

    def spy(*args):
        for chunk in real(*args):
            sizes.append(chunk.shape[0])
            yield chunk

    monkeypatch.setattr(precomputed_module, "_iter_npy", spy)
    real_load = np.load

    def load(*args, **kwargs):  # a memory map (the header) is fine, reading the whole array is not
        if kwargs.get("mmap_mode") is None:
            pytest.fail("a whole .npy must not be loaded")
        return real_load(*args, **kwargs)

    monkeypatch.setattr(np, "load", load)
    ident = Project.from_toml(path).run(progress=False)
    np.testing.assert_array_equal(ident.falsification.candidate_indices, expected)
    assert max(sizes) == 64 and sum(sizes) == 2000  # both files, in batches of 64 rows
    assert ident.sensor_mapping.ignored == ("T",)


def test_precomputed_csv_extra_columns_are_ignored_and_rows_must_agree(tmp_path):
    theta = np.random.default_rng(2).uniform(0, 1, (300, 2))
    pd.DataFrame(theta, columns=["a", "b"]).to_csv(tmp_path / "theta.csv", index=False)
    g = pd.DataFrame({"T": 0.0, "S2": 2.0 * theta[:, 1], "S1": theta[:, 0]})
    g.to_csv(tmp_path / "g.csv", index=False)
    toml = PROJECT.replace('[sampling]\nmethod = "grid"\npoints = { a = 11, b = 11 }\n', "").replace(
        'function = "m:g"', 'predictions = "g.csv"\nparameters = "theta.csv"\nbatch_size = 50')
    path = write(tmp_path, "sensor,value\nS1,0.5\nS2,1.0\n", toml)
    ident = Project.from_toml(path).run(progress=False)
    assert ident.sensor_mapping.ignored == ("T",) and ident.falsification.n_instances == 300
    g.iloc[:250].to_csv(tmp_path / "g.csv", index=False)
    with pytest.raises(ProjectError, match=r"g\.csv: expected as many rows as theta\.csv \(at least 300\), got 250"):
        Project.from_toml(path).run(progress=False)


def _precomputed_csv_project(tmp_path, rows=300):
    theta = np.random.default_rng(3).uniform(0, 1, (rows, 2))
    pd.DataFrame(theta, columns=["a", "b"]).to_csv(tmp_path / "theta.csv", index=False)
    g = pd.DataFrame({"S1": theta[:, 0], "S2": 2.0 * theta[:, 1]})
    g.to_csv(tmp_path / "g.csv", index=False)
    toml = PROJECT.replace('[sampling]\nmethod = "grid"\npoints = { a = 11, b = 11 }\n', "").replace(
        'function = "m:g"', 'predictions = "g.csv"\nparameters = "theta.csv"\nbatch_size = 64')
    return write(tmp_path, "sensor,value\nS1,0.5\nS2,1.0\n", toml), g


def test_precomputed_csv_gives_the_in_memory_candidates(tmp_path):
    # Read in chunks of 64 rows that do not line up with the reader's batches.
    path, g = _precomputed_csv_project(tmp_path)
    ident = Project.from_toml(path).run(progress=False)
    direct = edmf_rs.falsify(g.to_numpy(), [0.5, 1.0], ident.thresholds)
    assert 0 < direct.n_candidates < 300
    np.testing.assert_array_equal(ident.falsification.candidate_indices, direct.candidate_indices)


@pytest.mark.parametrize("file", ["g.csv", "theta.csv"])
@pytest.mark.parametrize("edit, got", [(lambda line: line.replace(".", ",", 1), 3),   # a decimal comma
                                       (lambda line: line.rsplit(",", 1)[0], 1)],     # a field lost
                         ids=["decimal-comma", "field-lost"])
def test_precomputed_csv_rows_of_another_width_are_refused_with_the_line(tmp_path, capsys, file, edit, got):
    # pandas.read_csv(usecols=...) dropped the extra field: "0,094,0.3" was read as 0 and 94,
    # shifting every column after it (58 candidates instead of 59 on the cantilever, exit 0).
    path, _ = _precomputed_csv_project(tmp_path)
    lines = (tmp_path / file).read_text().splitlines()
    lines[200] = edit(lines[200])
    (tmp_path / file).write_text("\n".join(lines) + "\n")
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"{file}: line 201: expected 2 fields as in the header, got {got}" in err
    assert not (tmp_path / "out" / "summary.json").exists()
