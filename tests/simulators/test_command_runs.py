"""External programs as models: a stand-in solver run once per instance, checked
against the same model as a Python function, and every way a run can fail."""

import json
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import command_model, write_project
from edmf_rs import cli
from edmf_rs.project import Project, ProjectError


def run(project, out, *extra):
    return cli.main(["run", str(project), "--out", str(out), "--no-progress", *extra])


def candidates(out):
    return pd.read_parquet(out / "candidates.parquet")


def test_command_gives_exactly_the_python_models_candidates(folder, tmp_path):
    python = write_project(folder, 'function = "lin_model:predict"', "py.toml")
    external = write_project(folder, command_model(), "cmd.toml")
    assert run(python, tmp_path / "py") == 0
    assert run(external, tmp_path / "cmd") == 0
    expected, got = candidates(tmp_path / "py"), candidates(tmp_path / "cmd")
    assert 0 < len(got) < 64
    pd.testing.assert_frame_equal(got, expected)  # values written with repr: bit for bit
    summary = json.loads((tmp_path / "cmd" / "summary.json").read_text())
    assert summary["model_evaluations"] == 64 and summary["failed_instances"] == 0
    assert list((tmp_path / "cmd" / "work").iterdir()) == []  # successful work folders removed
    assert (tmp_path / "cmd" / "failures.csv").read_text().splitlines() == ["instance,a,b,reason,stderr,work_folder"]


def test_json_output_and_custom_parser_give_the_same_predictions(folder, tmp_path):
    base = write_project(folder, command_model(), "csv.toml")
    json_ = write_project(folder, command_model(fmt="json"), "json.toml")
    custom = write_project(folder, command_model().replace('output = { file = "results.csv" }',
                                                           'output = { file = "results.csv", parser = "my_parser:read" }'),
                           "custom.toml")
    for p in (base, json_, custom):
        assert run(p, tmp_path / p.stem) == 0
    for p in (json_, custom):
        pd.testing.assert_frame_equal(candidates(tmp_path / p.stem), candidates(tmp_path / "csv"))


def test_keep_work_keeps_each_instances_deck_with_full_precision(folder, tmp_path):
    project = write_project(folder, command_model(keep_work="true"), n=4)
    assert run(project, tmp_path / "out") == 0
    works = sorted((tmp_path / "out" / "work").iterdir())
    assert len(works) == 4 and len({w.name for w in works}) == 4
    theta = Project.from_toml(project).sampling.all()
    for w, row in zip(works, theta):
        deck = (w / "deck.txt").read_text()
        values = dict(line.split(" = ") for line in deck.splitlines() if " = " in line)
        assert float(values["a"]) == row[0] and float(values["b"]) == row[1]
        assert (w / "stdout.txt").read_text().startswith("solving a=")


def test_some_runs_fail_they_are_data_not_candidates(folder, tmp_path):
    project = write_project(folder, command_model("fail_high_a"), sd=5.0)  # wide thresholds: all would pass
    assert run(project, tmp_path / "out") == 0
    theta = Project.from_toml(project).sampling.all()
    failing = np.flatnonzero(theta[:, 0] > 1.5)
    assert 0 < failing.size < 64 and failing[0] < 5  # some of the first five fail: no early stop
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["failed_instances"] == failing.size
    assert summary["candidates"] == 64 - failing.size
    assert not set(candidates(tmp_path / "out")["instance"]) & set(failing)
    table = pd.read_csv(tmp_path / "out" / "failures.csv")
    assert table["instance"].tolist() == failing.tolist()
    assert table["a"].tolist() == theta[failing, 0].tolist()
    assert table["reason"].str.startswith("exit code 3").all()
    assert table["stderr"].str.contains("solver diverged").all()
    for work in table["work_folder"]:  # failed work folders are kept
        assert (tmp_path / "out" / "work").resolve() in __import__("pathlib").Path(work).resolve().parents
        assert "stiffness matrix singular" in open(f"{work}/stderr.txt").read()
    assert "Failed model runs" in (tmp_path / "out" / "report.html").read_text()
    thresholds = pd.read_csv(tmp_path / "out" / "thresholds.csv")
    assert (thresholds["falsified"] == 0).all()  # failed instances are not counted as falsified


@pytest.mark.parametrize("mode, reason", [
    ("fail", "exit code 3"),
    ("garbage", "parsing results.csv failed"),
    ("missing", "missing sensor(s) S4"),
    ("unknown", "unknown sensor(s) S9"),
    ("nooutput", "output file 'results.csv' missing"),
    ("segv", "killed by signal SIGSEGV"),
    ("sleep=30", "timed out after 0.5 s"),
])
def test_first_runs_all_failing_stop_with_their_reasons(folder, tmp_path, capsys, mode, reason):
    # Only the sleeping solver needs a short timeout; the others get room to start on a loaded machine.
    timeout = 0.5 if mode.startswith("sleep") else 60
    project = write_project(folder, command_model(mode, timeout=timeout, stop_after_failures=2, workers=2))
    assert run(project, tmp_path / "out") == 1
    err = capsys.readouterr().err
    assert "the first 2 instances all failed" in err
    assert reason in err and "instance 0 (a=" in err and "instance 1 (a=" in err
    assert "command: " + sys.executable in err and "work folder " + str(tmp_path / "out" / "work") in err
    table = pd.read_csv(tmp_path / "out" / "failures.csv")
    assert table["instance"].tolist()[:2] == [0, 1]
    assert not (tmp_path / "out" / "summary.json").exists()


def test_a_parser_that_raises_fails_the_instance(folder, tmp_path, capsys):
    model = command_model(stop_after_failures=1).replace(
        'output = { file = "results.csv" }', 'output = { file = "results.csv", parser = "my_parser:broken" }')
    assert run(write_project(folder, model), tmp_path / "out") == 1
    assert "RuntimeError: cannot read this format" in capsys.readouterr().err


def test_max_failure_rate_stops_the_run(folder, tmp_path, capsys):
    project = write_project(folder, command_model("fail_high_a", max_failure_rate=0.05), sd=5.0)
    assert run(project, tmp_path / "out") == 1
    err = capsys.readouterr().err
    assert "more than max_failure_rate = 0.05 allows" in err
    assert "4 of 64 instances failed already" in err  # stops at the first failure beyond 5 % of 64


@pytest.mark.parametrize("edit, message", [
    (lambda m: m.replace('"ok"', '"{E}"'), "command[2] ('{E}'): placeholder {E} names no parameter"),
    (lambda m: m.replace(sys.executable, "no-such-solver-xyz"), "model.command: program 'no-such-solver-xyz' not found"),
    (lambda m: m.replace('"deck.txt"', '"nodeck.txt"'), "model.files: cannot read template"),
    (lambda m: m.replace('"results.csv" }', '"out.dat" }'), "model.output.parser: expected 'module:function'"),
    (lambda m: m + "\nfunction = 'lin_model:predict'", "either"),
])
def test_setup_errors_name_the_key_before_anything_runs(folder, tmp_path, capsys, edit, message):
    project = write_project(folder, edit(command_model()))
    assert run(project, tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert message in err or (message == "either" and "not both function and command" in err)
    assert str(project) in err
    assert not (tmp_path / "out").exists()


def test_template_placeholder_naming_no_parameter(folder):
    (folder / "deck.txt").write_text("a = {a}\nb = {b}\nc = {K_rot}\n")
    with pytest.raises(ProjectError, match=r"deck.txt: placeholder \{K_rot\} names no parameter \(the parameters are: a, b\)"):
        Project.from_toml(write_project(folder, command_model()))


def test_a_relative_program_is_found_in_the_project_folder(folder, tmp_path):
    script = folder / "run.sh"
    script.write_text(f"#!/bin/sh\nexec {sys.executable} {folder / 'solver.py'} ok csv\n")
    script.chmod(0o755)
    model = 'command = ["./run.sh"]\nfiles = ["deck.txt"]'
    assert run(write_project(folder, model, n=8), tmp_path / "out") == 0
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["failed_instances"] == 0


def test_a_binary_template_is_refused(folder):
    (folder / "deck.txt").write_bytes(b"\xff\xfe\x00binary")
    with pytest.raises(ProjectError, match="deck.txt' is not UTF-8 text"):
        Project.from_toml(write_project(folder, command_model()))
