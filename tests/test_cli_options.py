"""The command line a user expects (issue 12, part 7): --version, --dry-run,
--threads, a safe --out, progress with total and ETA, self-describing help."""

import io
import json
import shutil
import subprocess
import sys
from pathlib import Path

import edmf_rs
import pytest
from edmf_rs import cli
from edmf_rs.project import Project
from edmf_rs.project.progress import Progress

EXAMPLES = Path(edmf_rs.__file__).parent / "examples" / "projects"


def cantilever(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("cantilever.toml", "cantilever_model.py", "cantilever.csv"):
        shutil.copy(EXAMPLES / name, folder / name)
    return folder / "cantilever.toml"


def test_version(capsys):
    with pytest.raises(SystemExit) as done:
        cli.main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"edmf-rs {edmf_rs.__version__}"


def test_reproduce_help_describes_itself():
    proc = subprocess.run([sys.executable, "-m", "edmf_rs", "reproduce", "--help"], capture_output=True, text=True)
    assert proc.returncode == 0
    assert "Reproduce Goulet & Smith (2013)" in proc.stdout and "Table 1" in proc.stdout


def test_run_help_says_a_project_runs_code():
    proc = subprocess.run([sys.executable, "-m", "edmf_rs", "run", "--help"], capture_output=True, text=True)
    assert "runs the code it names" in " ".join(proc.stdout.split())


def test_dry_run_prints_the_plan_and_writes_nothing(tmp_path, capsys):
    path = cantilever(tmp_path)
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "101 model instances (grid 101 = 101 instances), 1 parameter, 10 sensors" in out
    assert "model checked on 2 instances" in out and "estimated model time" in out
    assert "prognosis functions checked on 2 instances: tip deflection under 2F" in out
    assert not (tmp_path / "out").exists()


def test_threads_sets_the_rust_pool(tmp_path):
    before = edmf_rs.get_num_threads()
    try:
        assert cli.main(["run", str(cantilever(tmp_path)), "--dry-run", "--threads", "1"]) == 0
        assert edmf_rs.get_num_threads() == 1
        assert cli.main(["run", str(cantilever(tmp_path)), "--dry-run", "--threads", "0"]) == 2
    finally:
        edmf_rs.set_num_threads(before)


@pytest.mark.parametrize("threads", ["100000", "99999999999999999999"])
def test_too_many_threads_are_refused_naming_the_option_and_value(tmp_path, capsys, threads):
    # It said "n: ..., got 100000" (an argument the user never gave) and "got 9223372036854775807".
    assert cli.main(["run", str(cantilever(tmp_path)), "--dry-run", "--threads", threads]) == 2
    err = capsys.readouterr().err
    assert "--threads: expected a number of threads from 1 to " in err and err.rstrip().endswith(f"got {threads}")


def test_out_refuses_a_foreign_folder_unless_forced(tmp_path, capsys):
    path = cantilever(tmp_path / "p")
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert cli.main(["run", str(path), "--out", str(out), "--no-progress"]) == 2
    assert "not empty and holds no earlier run of cantilever.toml; choose an empty or new folder, or pass --force" \
        in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    assert cli.main(["run", str(path), "--out", str(out), "--no-progress", "--force"]) == 0
    assert (out / "notes.txt").read_text() == "mine" and (out / "summary.json").is_file()
    # the same project may write into its own earlier run without --force
    assert cli.main(["run", str(path), "--out", str(out), "--no-progress"]) == 0
    other = cantilever(tmp_path / "q")
    other.rename(other.with_name("other.toml"))
    assert cli.main(["run", str(other.with_name("other.toml")), "--out", str(out), "--no-progress"]) == 2


def test_out_never_overwrites_an_input(tmp_path, capsys):
    path = cantilever(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    shutil.move(tmp_path / "cantilever.csv", out / "thresholds.csv")  # the measurements at out/thresholds.csv
    path.write_text(path.read_text().replace('file = "cantilever.csv"', 'file = "out/thresholds.csv"'))
    before = (out / "thresholds.csv").read_text()
    for extra in ([], ["--force"]):
        assert cli.main(["run", str(path), "--out", str(out), "--no-progress", *extra]) == 2
        assert "would overwrite" in capsys.readouterr().err
    assert (out / "thresholds.csv").read_text() == before


def test_out_naming_a_file_is_refused_before_the_run(tmp_path, capsys):
    path = cantilever(tmp_path)
    path.write_text(path.read_text().replace("cantilever_model:deflections", "cantilever_model:slow"))
    (tmp_path / "cantilever_model.py").write_text((tmp_path / "cantilever_model.py").read_text() + (
        "\n\ndef slow(theta):\n    raise AssertionError('the model must not run')\n"))
    (tmp_path / "file.txt").write_text("x")
    assert cli.main(["run", str(path), "--out", str(tmp_path / "file.txt"), "--no-progress"]) == 2
    assert f"--out {tmp_path / 'file.txt'}: expected a folder, it is a file" in capsys.readouterr().err
    assert (tmp_path / "file.txt").read_text() == "x"


def test_progress_shows_total_and_eta_one_line_per_update():
    out = io.StringIO()
    progress = Progress(400, stream=out, delay=0.0, interval=0.0)
    for _ in range(4):
        progress.update(100)
    progress.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 5 and "\r" not in out.getvalue()
    assert lines[0].startswith("falsifying: 100 / 400 instances (25.0 %), ") and ", ETA " in lines[0]
    assert lines[3].startswith("falsifying: 400 / 400 instances (100.0 %)") and "ETA" not in lines[3]
    unknown = io.StringIO()
    progress = Progress(None, stream=unknown, delay=0.0, interval=0.0)
    progress.update(7)
    assert unknown.getvalue().startswith("falsifying: 7 instances, ")


def test_project_run_reports_progress_per_batch(tmp_path):
    path = cantilever(tmp_path)
    path.write_text(path.read_text().replace('sensors = ["D1"', 'batch_size = 25\nsensors = ["D1"'))
    out = io.StringIO()
    Project.from_toml(path).run(progress=Progress(101, stream=out, delay=0.0, interval=0.0))
    lines = out.getvalue().splitlines()
    assert [line.split(" instances")[0] for line in lines[:5]] == [
        "falsifying: 25 / 101", "falsifying: 50 / 101", "falsifying: 75 / 101", "falsifying: 100 / 101",
        "falsifying: 101 / 101"]


def test_summary_records_the_project(tmp_path):
    path = cantilever(tmp_path)
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--no-progress"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["project"]["file"] == "cantilever.toml"
