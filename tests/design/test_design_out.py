"""`edmf-rs design --out`: refused like `edmf-rs run --out` (a file, a non-empty
folder of other things unless --force) and never overwriting an input."""

import argparse
import re
import shutil
from pathlib import Path

import pytest
from edmf_rs.cli import main
from edmf_rs.design.cli import run_design
from edmf_rs.project import ProjectError

PROJECT = Path(__file__).resolve().parents[2] / "python/edmf_rs/examples/design_projects/girder-design.toml"


@pytest.fixture
def tiny_project(tmp_path):
    """The girder design shrunk to 128 instances and 50 simulations, in its own folder."""
    folder = tmp_path / "project"
    folder.mkdir()
    text = PROJECT.read_text().replace("n = 4096", "n = 128").replace("n_simulations = 1000", "n_simulations = 50")
    assert "n = 128" in text and "n_simulations = 50" in text
    (folder / "girder-design.toml").write_text(text)
    shutil.copy(PROJECT.parent / "girder-candidates.csv", folder)
    return folder / "girder-design.toml"


@pytest.mark.filterwarnings("ignore::UserWarning")  # few Monte Carlo samples in the tails: not what is tested
def test_a_folder_of_other_files_is_refused_unless_force(tiny_project, tmp_path, capsys):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "report.html").write_text("my report")
    assert main(["design", str(tiny_project), "--out", str(mine)]) == 2
    err = capsys.readouterr().err
    assert f"--out {mine}: the folder is not empty" in err and "--force" in err
    assert (mine / "report.html").read_text() == "my report"
    # The design's own earlier output is written again without --force.
    out = tmp_path / "out"
    assert main(["design", str(tiny_project), "--out", str(out)]) == 0
    first = (out / "design.csv").read_text()
    assert main(["design", str(tiny_project), "--out", str(out)]) == 0
    assert (out / "design.csv").read_text() == first
    # --force writes into the user's folder, never over a file of the user's named like an output.
    capsys.readouterr()
    assert main(["design", str(tiny_project), "--out", str(mine), "--force"]) == 2
    assert "never replaces files a design did not write, and it holds report.html" in capsys.readouterr().err
    assert (mine / "report.html").read_text() == "my report"
    (mine / "report.html").rename(mine / "my-report.html")
    assert main(["design", str(tiny_project), "--out", str(mine), "--force"]) == 0
    assert "<!doctype html>" in (mine / "report.html").read_text()
    assert (mine / "my-report.html").read_text() == "my report"


def test_an_input_is_never_overwritten_even_with_force(tiny_project, monkeypatch, capsys):
    folder = tiny_project.parent
    (folder / "girder-candidates.csv").rename(folder / "design.csv")
    tiny_project.write_text(tiny_project.read_text().replace("girder-candidates.csv", "design.csv"))
    before = (folder / "design.csv").read_bytes()
    monkeypatch.chdir(folder)
    target = re.escape(str(folder.resolve() / "design.csv"))
    overwrite = rf"--out \.: the design would overwrite {target}, an input of girder-design\.toml; choose another"
    assert main(["design", "girder-design.toml", "--out", "."]) == 2
    assert re.search(overwrite, capsys.readouterr().err)
    with pytest.raises(ProjectError, match=overwrite):
        run_design("girder-design.toml", ".", force=True)
    assert (folder / "design.csv").read_bytes() == before
    assert sorted(p.name for p in folder.iterdir()) == ["design.csv", "girder-design.toml"]


def test_out_that_is_a_file_is_refused(tiny_project, tmp_path, capsys):
    (tmp_path / "f.txt").write_text("notes")
    assert main(["design", str(tiny_project), "--out", str(tmp_path / "f.txt")]) == 2
    assert f"--out {tmp_path / 'f.txt'}: expected a folder, it is a file" in capsys.readouterr().err
    assert (tmp_path / "f.txt").read_text() == "notes"


def test_design_subcommand_takes_force():
    from edmf_rs.design.cli import add_parser

    parser = argparse.ArgumentParser()
    add_parser(parser.add_subparsers(dest="command"), argparse.ArgumentParser(add_help=False))
    args = parser.parse_args(["design", "p.toml", "--out", "o", "--force"])
    assert (args.project, args.out, args.force) == ("p.toml", "o", True)
    assert parser.parse_args(["design", "p.toml"]).force is False
