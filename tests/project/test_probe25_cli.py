"""Faults a probe of the command line found (session 25): a model raising a
BaseException subclass, --force replacing a user's file named like an output,
--out folders that cannot be created or are named by an empty string, the
instance limit's message without the project file, boolean predictions."""

import textwrap

import pytest
from edmf_rs import cli

from _projects import LINEAR_CSV, LINEAR_MODEL, project_text, write_project

MODELS = LINEAR_MODEL + textwrap.dedent("""
    class Abort(BaseException):
        pass

    def base_exception(theta):
        raise Abort("solver aborted")

    def memory(theta):
        raise MemoryError

    def booleans(theta):
        return theta @ A > 1.0
""")


def linear(folder, function="model:predict", points=None):
    text = project_text(
        parameters={"a": (0.0, 2.0), "b": (0.0, 2.0)},
        sampling={"method": "grid", "points": points or {"a": 5, "b": 5}},
        model={"function": function}, measurements={"file": "meas.csv"},
        uncertainty=({"kind": "model", "distribution": "normal", "sd": 0.3},))
    return write_project(folder, text, modules={"model": MODELS}, csv=LINEAR_CSV)


def test_a_model_raising_a_base_exception_subclass_is_reported_as_its_failure(tmp_path, capsys):
    # It escaped `except Exception` and ended in a raw traceback.
    path = linear(tmp_path, "model:base_exception")
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert f"{path}: model.function = 'model:base_exception' raised Abort: solver aborted" in err


def test_an_exception_without_a_message_is_named_without_a_dangling_colon(tmp_path, capsys):
    # It said "raised MemoryError: , on batch 0".
    path = linear(tmp_path, "model:memory")
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--no-progress"]) == 1
    assert "raised MemoryError, on batch 0" in capsys.readouterr().err


def test_force_never_replaces_a_users_file_named_like_an_output(tmp_path, capsys):
    # --force wrote summary.json over the user's own summary.json.
    path = linear(tmp_path / "p")
    out = tmp_path / "mine"
    out.mkdir()
    (out / "summary.json").write_text("precious")
    (out / "notes.txt").write_text("mine")
    assert cli.main(["run", str(path), "--out", str(out), "--no-progress", "--force"]) == 2
    err = capsys.readouterr().err
    assert f"--out {out}: --force writes into the folder but never replaces files a run did not write" in err
    assert "summary.json" in err
    assert (out / "summary.json").read_text() == "precious" and (out / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "summary.json"]
    (out / "summary.json").unlink()
    assert cli.main(["run", str(path), "--out", str(out), "--no-progress", "--force"]) == 0
    assert (out / "notes.txt").read_text() == "mine"
    # its own earlier run is overwritten, with or without --force
    for extra in ([], ["--force"]):
        assert cli.main(["run", str(path), "--out", str(out), "--no-progress", *extra]) == 0


def test_an_out_folder_that_cannot_be_created_names_the_option(tmp_path, capsys):
    # It said "[Errno 20] Not a directory: ..." with no --out.
    path = linear(tmp_path)
    (tmp_path / "afile").write_text("x")
    out = tmp_path / "afile" / "sub"
    assert cli.main(["run", str(path), "--out", str(out), "--no-progress"]) == 2
    assert f"--out {out}: cannot write the output folder" in capsys.readouterr().err
    assert (tmp_path / "afile").read_text() == "x"


def test_an_empty_out_is_refused_not_taken_for_the_current_folder(tmp_path, capsys, monkeypatch):
    path = linear(tmp_path / "p")
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", str(path), "--out", "", "--no-progress", "--force"]) == 2
    assert "--out: expected an output folder, got an empty name" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p"]


def test_the_instance_limit_names_the_project_file(tmp_path, capsys):
    path = linear(tmp_path, points={"a": 1_000_000, "b": 1_000_000})
    assert cli.main(["run", str(path), "--dry-run"]) == 2
    assert f"{path}: sampling: the run has 1,000,000,000,000 model instances" in capsys.readouterr().err


@pytest.mark.parametrize("dry_run", [True, False])
def test_boolean_predictions_are_refused(tmp_path, capsys, dry_run):
    # True/False were read as 1.0/0.0 and falsified as predictions.
    path = linear(tmp_path, "model:booleans")
    extra = ["--dry-run"] if dry_run else ["--out", str(tmp_path / "out"), "--no-progress"]
    assert cli.main(["run", str(path), *extra]) == 2
    assert f"{path}: model.function = 'model:booleans': returned ndarray of dtype bool" in capsys.readouterr().err


@pytest.mark.parametrize("header, hint", [
    ("sensor;value", "read as one column 'sensor;value': separate the columns with ','"),
    ("Sensor,Value", "the column names are lower case: sensor, value"),
    ("name,reading", None),
])
def test_a_measurements_header_says_why_it_lacks_sensor_and_value(tmp_path, header, hint):
    from edmf_rs.project.measurements import read_measurements
    from edmf_rs.project.schema import ProjectError

    f = tmp_path / "m.csv"
    f.write_text(f"{header}\nD1{header[6] if len(header) > 6 else ','}0.5\n")
    with pytest.raises(ProjectError, match="line 1: expected a header with columns sensor,value") as exc:
        read_measurements(f)
    assert (hint in str(exc.value)) if hint else str(exc.value).endswith("missing sensor, value")


def test_one_idle_sensor_is_named_in_the_singular():
    import numpy as np
    import edmf_rs
    from edmf_rs.project.diagnostics import findings, leave_one_out

    # Row 0 a candidate; S1 alone falsifies row 1, S3 alone row 3; S2 only with S1 (row 2).
    g = np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0], [5.0, 5.0, 0.0], [0.0, 0.0, 5.0]])
    result = edmf_rs.falsify(g, np.zeros(3), edmf_rs.Thresholds(low=[-1.0] * 3, high=[1.0] * 3), progress=False)
    text = " ".join(findings(leave_one_out(result, ["S1", "S2", "S3"])))
    assert ("Leaving out S2 would not change the candidate set (every instance it falsifies, another sensor "
            "falsifies too).") in text


def test_a_sensor_excluded_twice_is_refused_by_name(tmp_path, capsys):
    project = linear(tmp_path)
    text = project.read_text()
    assert "[measurements]" in text
    project.write_text(text.replace("[measurements]\n", "[measurements]\nexclude = [\"S1\", \"S1\"]\n", 1))
    assert cli.main(["run", str(project), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "measurements.exclude: expected each sensor name once (S1 more than once), got ['S1', 'S1']" in err
