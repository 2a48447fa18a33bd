"""What an external program's model is given and keyed by: placeholders for any
parameter name, template and output paths kept inside each run's work folder, and
a prediction-store key that follows the program's own files."""

import json
import os
import sys
from pathlib import Path

import pandas as pd
import pytest
from conftest import command_model, write_project
from edmf_rs import cli
from edmf_rs.simulators import command as command_module
from edmf_rs.simulators.command import CommandModel, CommandSpec


def run(project, out, *extra):
    return cli.main(["run", str(project), "--out", str(out), "--no-progress", *extra])


def candidates(out):
    return pd.read_parquet(out / "candidates.parquet")


def summary(out):
    return json.loads((out / "summary.json").read_text())


# The program writes results.csv with its first argument as sensor S's prediction.
ECHO = ("import sys; open('results.csv', 'w').write('sensor,value' + chr(10) + 'S,' + sys.argv[1] + chr(10) "
        "+ 'T,' + open('deck.txt').read().strip() + chr(10))")


# --- 1. placeholders for any parameter name -------------------------------------------------------

@pytest.mark.parametrize("name", ["é", "E mod", "Ε_μ", "1"])
def test_any_parameter_name_is_substituted_in_command_and_templates(tmp_path, name):
    (tmp_path / "deck.txt").write_text(f"{{{name}}}\n")
    spec = CommandSpec((sys.executable, "-c", ECHO, f"{{{name}}}"), ("deck.txt",), path=tmp_path)
    model = CommandModel(spec, (name, "b"), ("S", "T"))
    assert model.run(0, [0.1 + 0.2, 7.0], tmp_path) == [0.1 + 0.2, 0.1 + 0.2]


def test_project_with_non_ascii_and_spaced_parameter_names_runs_like_ascii_names(folder, tmp_path):
    ascii_ = write_project(folder, command_model(), "ascii.toml")
    assert run(ascii_, tmp_path / "ascii") == 0
    named = folder / "named.toml"
    named.write_text(ascii_.read_text().replace("[parameters.a]", '[parameters."é"]')
                     .replace("[parameters.b]", '[parameters."E mod"]'))
    (folder / "deck.txt").write_text("# stand-in deck\na = {é}\nb = {E mod}\n")
    assert run(named, tmp_path / "named") == 0
    assert summary(tmp_path / "named")["failed_instances"] == 0
    got, expected = candidates(tmp_path / "named"), candidates(tmp_path / "ascii")
    assert 0 < len(got) < 64
    assert got["instance"].tolist() == expected["instance"].tolist()
    assert got["é"].tolist() == expected["a"].tolist() and got["E mod"].tolist() == expected["b"].tolist()


@pytest.mark.parametrize("where", ["command", "template"])
def test_a_placeholder_naming_no_parameter_is_refused(tmp_path, where):
    for placeholder in ["{ü}", "{éa}", "{c}", "{E_mod}"]:
        (tmp_path / "deck.txt").write_text(f"x = {placeholder}\n" if where == "template" else "x = 1\n")
        args = (sys.executable, "-c", ECHO, placeholder if where == "command" else "1")
        with pytest.raises(ValueError, match=f"placeholder {placeholder} names no parameter"):
            CommandModel(CommandSpec(args, ("deck.txt",), path=tmp_path), ("é", "E mod"), ("S", "T"))


def test_other_braces_are_kept(tmp_path):
    (tmp_path / "deck.txt").write_text('{"x": {é}, "y": {{é}}, "z": {1}, "w": {E mod2} }\n')
    (tmp_path / "p.py").write_text("def read(path):\n    open(path.parent / 'seen', 'w').write(open(path).read())\n"
                                   "    return {'S': 1.0}\n")
    spec = CommandSpec(("cp", "deck.txt", "out.txt"), ("deck.txt",), "out.txt", "p:read", tmp_path, keep_work=True)
    model = CommandModel(spec, ("é", "E mod"), ("S",))
    (tmp_path / "w").mkdir()
    assert model.run(0, [2.5, 1.0], tmp_path / "w") == [1.0]
    (work,) = (tmp_path / "w").iterdir()
    assert (work / "seen").read_text() == '{"x": 2.5, "y": {é}, "z": {1}, "w": {E mod2} }\n'


@pytest.mark.parametrize("name", ["a}b", "{a}", ""])
def test_a_parameter_name_no_placeholder_can_name_is_refused(folder, tmp_path, capsys, name):
    project = write_project(folder, command_model(), "p.toml")
    project.write_text(project.read_text().replace("[parameters.b]", f"[parameters.{json.dumps(name)}]"))
    (folder / "deck.txt").write_text("# stand-in deck\na = {a}\nb = 1\n")
    assert run(project, tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert str(project) in err and "model.command" in err and repr(name) in err
    assert "any parameter name except an empty one or one with '{' or '}'" in err


# --- 2. files and output stay inside the work folder -----------------------------------------------

def test_absolute_template_path_is_refused_and_the_template_is_never_overwritten(folder, tmp_path, capsys):
    tpl = tmp_path / "tpl"
    tpl.mkdir()
    (tpl / "deck.txt").write_text("# stand-in deck\na = {a}\nb = {b}\n")
    project = write_project(folder, command_model().replace('files = ["deck.txt"]',
                                                            f"files = [{json.dumps(str(tpl / 'deck.txt'))}]"))
    assert run(project, tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert str(project) in err and "model.files: expected a template's path relative to the project folder" in err
    assert repr(str(tpl / "deck.txt")) in err
    assert (tpl / "deck.txt").read_text() == "# stand-in deck\na = {a}\nb = {b}\n"


def test_absolute_output_path_is_refused_not_read_by_every_instance(folder, tmp_path, capsys):
    fixed = tmp_path / "fixed.csv"
    fixed.write_text("sensor,value\nS1,1.0\nS2,1.0\nS3,1.0\nS4,1.0\n")
    project = write_project(folder, command_model().replace('output = { file = "results.csv" }',
                                                            f"output = {json.dumps(str(fixed))}"))
    assert run(project, tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert str(project) in err and "model.output: expected the output file's path relative to each run's work" in err
    assert repr(str(fixed)) in err
    assert not (tmp_path / "out" / "candidates.parquet").exists()


@pytest.mark.parametrize("key, value", [("files", "../{name}/deck.txt"), ("files", "sub/../../{name}/deck.txt"),
                                        ("output", "../results.csv"), ("output", "..")])
def test_paths_leaving_the_work_folder_are_refused(folder, tmp_path, key, value):
    (folder / "sub").mkdir()
    (folder / "sub" / "deck.txt").write_text("a = {a}\n")
    inside = CommandSpec(("cp", "sub/deck.txt", "results.csv"), ("sub/../deck.txt", "./sub/deck.txt"),
                         "./results.csv", path=folder)
    CommandModel(inside, ("a", "b"), ("S1", "S2", "S3", "S4"))  # '..' that stays inside is fine
    value = value.format(name=folder.name)
    files, output = ([value], "results.csv") if key == "files" else (["deck.txt"], value)
    spec = CommandSpec((sys.executable, str(folder / "solver.py"), "ok", "csv"), tuple(files), output, path=folder)
    with pytest.raises(ValueError, match=rf"^{key}: expected .* without '\.\.' leaving it, got '{value}'$"):
        CommandModel(spec, ("a", "b"), ("S1", "S2", "S3", "S4"))


# --- 3. the store key follows the program's files ---------------------------------------------------

def test_changing_the_solver_script_evaluates_again(folder, tmp_path):
    project = write_project(folder, command_model())
    out = tmp_path / "out"
    assert run(project, out) == 0
    before = candidates(out)
    solver = folder / "solver.py"
    solver.write_text(solver.read_text().replace("a * A[0][j] + b * A[1][j]", "a * A[0][j] + b * A[1][j] + 0.5"))
    assert run(project, out) == 0
    s = summary(out)
    assert s["model_evaluations"] == 64 and s["reused_evaluations"] == 0
    assert not candidates(out).equals(before)
    assert run(project, out) == 0  # unchanged again: all reused
    assert summary(out)["reused_evaluations"] == 64


def _model(folder, command, files=("deck.txt",)):
    return CommandModel(CommandSpec(tuple(command), files, path=folder), ("a", "b"), ("S1", "S2", "S3", "S4"))


def test_fingerprint_covers_a_program_found_on_path(folder, tmp_path, monkeypatch):
    bin_ = tmp_path / "bin"
    bin_.mkdir()
    program = bin_ / "standin-solver"
    program.write_text(f"#!{sys.executable}\n" + (folder / "solver.py").read_text())
    program.chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_}{os.pathsep}{os.environ['PATH']}")
    first = _model(folder, ["standin-solver", "ok", "csv"]).fingerprint()
    assert first == _model(folder, ["standin-solver", "ok", "csv"]).fingerprint()
    program.write_text(program.read_text() + "\n# patched\n")
    assert _model(folder, ["standin-solver", "ok", "csv"]).fingerprint() != first


def test_fingerprint_covers_a_relative_program_and_script_arguments(folder):
    (folder / "run.sh").write_text("#!/bin/sh\nexec python3 \"$@\"\n")
    (folder / "run.sh").chmod(0o755)
    first = _model(folder, ["./run.sh", "solver.py", "ok", "csv"]).fingerprint()
    (folder / "solver.py").write_text((folder / "solver.py").read_text() + "\n# patched\n")
    second = _model(folder, ["./run.sh", "solver.py", "ok", "csv"]).fingerprint()
    assert second != first
    (folder / "run.sh").write_text("#!/bin/sh\nexec python3 -u \"$@\"\n")
    assert _model(folder, ["./run.sh", "solver.py", "ok", "csv"]).fingerprint() != second


def test_fingerprint_records_size_and_mtime_of_a_file_over_the_hash_limit(folder, monkeypatch):
    monkeypatch.setattr(command_module, "HASH_LIMIT", 100)
    solver = folder / "solver.py"
    opened = []
    real_open = open

    def spy(file, *a, **k):
        opened.append(Path(file))
        return real_open(file, *a, **k)

    monkeypatch.setattr("builtins.open", spy)
    first = _model(folder, [sys.executable, str(solver), "ok", "csv"]).fingerprint()
    assert solver not in opened  # not read: too large
    os.utime(solver, ns=(solver.stat().st_atime_ns, solver.stat().st_mtime_ns + 10**9))
    assert _model(folder, [sys.executable, str(solver), "ok", "csv"]).fingerprint() != first


# --- a script beside the project file, named relatively -----------------------------------------

def test_a_script_beside_the_project_file_is_found_by_every_run(folder, tmp_path):
    """Runs start in their own work folder; `python solver.py` names the script beside the project
    file (as its fingerprint does), which is passed by its absolute path and never copied."""
    absolute = write_project(folder, command_model(), "absolute.toml")
    assert run(absolute, tmp_path / "absolute") == 0
    relative = write_project(folder, command_model().replace("{solver}", "solver.py"), "relative.toml")
    assert 'command = ["' + sys.executable + '", "solver.py", "ok", "csv"]' in relative.read_text()
    assert run(relative, tmp_path / "relative") == 0
    assert candidates(tmp_path / "relative").equals(candidates(tmp_path / "absolute"))
    assert summary(tmp_path / "relative")["model_evaluations"] == 64


def test_only_arguments_naming_a_project_file_are_rewritten(folder):
    (folder / "results.csv").write_text("sensor,value\n")  # the output's name: passed as written
    spec = CommandSpec(("cp", "deck.txt", "results.csv", "solver.py", "{a}", "absent.txt", "-i", "solver.py"),
                       ("deck.txt",), path=folder)
    model = CommandModel(spec, ("a", "b"), ("S",))
    assert model.project_files == {3: str(folder.resolve() / "solver.py"), 7: str(folder.resolve() / "solver.py")}
