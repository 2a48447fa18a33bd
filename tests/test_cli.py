"""The edmf-rs command line: shipped examples run by name, user errors exit 2."""

import json
import subprocess
import sys

from edmf_rs import cli


def test_shipped_examples_are_listed():
    assert {"cantilever", "girder", "girder-sg5-excluded"} <= set(cli.example_names())


def test_run_a_shipped_example(tmp_path, capsys):
    out = tmp_path / "cantilever"
    assert cli.main(["run", "--example", "cantilever", "--out", str(out), "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["candidates"] > 0 and not summary["model_class_falsified"]
    assert (out / "report.html").is_file()
    assert "candidate model set" in capsys.readouterr().out


def test_user_errors_exit_2_without_a_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[identification]\nphi = 2.0\n")
    proc = subprocess.run([sys.executable, "-m", "edmf_rs", "run", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert proc.stderr.startswith("edmf-rs: error: ") and "phi" in proc.stderr
    proc = subprocess.run([sys.executable, "-m", "edmf_rs", "reproduce", "--seeds", "0", "--out", str(tmp_path)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "--seeds" in proc.stderr
