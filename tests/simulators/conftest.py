"""A stand-in solver (a Python script run with sys.executable) and project files
that use it: the linear model g(a, b) = a A[0] + b A[1] of four sensors."""

import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import _projects
from _projects import toml_value

A = np.array([[1.0, 2.0, 0.5, -1.0], [0.3, -0.2, 1.5, 0.8]])
SENSORS = ("S1", "S2", "S3", "S4")

SOLVER = textwrap.dedent("""
    # Stand-in FE solver: reads deck.txt, writes results.csv or results.json.
    import json, os, signal, sys, time
    mode, fmt = sys.argv[1], sys.argv[2]
    values = dict(line.split(" = ") for line in open("deck.txt").read().splitlines() if " = " in line)
    a, b = float(values["a"]), float(values["b"])
    A = [[1.0, 2.0, 0.5, -1.0], [0.3, -0.2, 1.5, 0.8]]
    preds = {f"S{j + 1}": a * A[0][j] + b * A[1][j] for j in range(4)}
    print(f"solving a={a!r} b={b!r}")
    if mode == "fail" or (mode == "fail_high_a" and a > 1.5):
        print("step 7: stiffness matrix singular", file=sys.stderr)
        print("solver diverged", file=sys.stderr)
        sys.exit(3)
    if mode == "sleep_high_a" and a > 1.5:
        open("pid", "w").write(str(os.getpid()))
        time.sleep(60)
    if mode.startswith("sleep="):
        time.sleep(float(mode[6:]))
    if mode.startswith("slow_high_a=") and a > 1.5:
        time.sleep(float(mode[12:]))
    if mode == "fail_high_a_env" and a > 1.5 and os.environ.get("STANDIN_FAIL"):
        print("licence server not answering", file=sys.stderr)
        sys.exit(4)
    if mode == "segv":
        os.kill(os.getpid(), signal.SIGSEGV)
    if mode == "nooutput":
        sys.exit(0)
    if mode == "missing":
        del preds["S4"]
    if mode == "unknown":
        preds["S9"] = 1.0
    if mode == "garbage":
        open("results.csv", "w").write("sensor,value\\nS1,not-a-number\\n")
        sys.exit(0)
    if fmt == "json":
        json.dump(preds, open("results.json", "w"))
    else:
        with open("results.csv", "w") as fh:
            fh.write("sensor,value\\n" + "".join(f"{k},{v!r}\\n" for k, v in preds.items()))
""")

MODEL = textwrap.dedent("""
    import numpy as np
    A = np.array([[1.0, 2.0, 0.5, -1.0], [0.3, -0.2, 1.5, 0.8]])
    def predict(theta):
        return theta[:, 0:1] * A[0] + theta[:, 1:2] * A[1]
""")

PARSER = textwrap.dedent("""
    def read(path):
        out = {}
        for line in open(path):
            k, v = line.split(",")
            if k == "sensor":
                continue
            out[k] = float(v)
        return out
    def broken(path):
        raise RuntimeError("cannot read this format")
""")


def project_text(model: str, *, n: int = 64, sd: float = 0.3, exclude=(), extra_model: str = "") -> str:
    """A project file: a, b in [0, 2], Sobol' n instances, measurements from a = b = 1."""
    return _projects.project_text(
        identification={"name": "stand-in", "phi": 0.95}, parameters={"a": (0.0, 2.0), "b": (0.0, 2.0)},
        sampling={"method": "sobol", "n": n, "seed": 3}, model=f"{model}\n{extra_model}".replace("'", '"'),
        measurements={"file": "meas.csv", "exclude": list(exclude)},
        uncertainty=[{"name": "model", "kind": "model", "distribution": "normal", "sd": sd}])


def command_model(mode: str = "ok", fmt: str = "csv", **keys) -> str:
    """The [model] lines for the stand-in solver."""
    output = "results.json" if fmt == "json" else "results.csv"
    lines = [f"command = {toml_value([sys.executable, '{solver}', mode, fmt])}", 'files = ["deck.txt"]',
             f"output = {toml_value({'file': output})}"]
    lines += [f"{k} = {v}" for k, v in keys.items()]
    return "\n".join(lines)


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    """A project folder with the solver, its deck template, a Python twin of the model and measurements."""
    (tmp_path / "solver.py").write_text(SOLVER)
    (tmp_path / "deck.txt").write_text("# stand-in deck\na = {a}\nb = {b}\n")
    (tmp_path / "lin_model.py").write_text(MODEL)
    (tmp_path / "my_parser.py").write_text(PARSER)
    y = np.array([1.0, 1.0]) @ A + np.array([0.05, -0.1, 0.1, 0.0])
    (tmp_path / "meas.csv").write_text("sensor,value\n" + "".join(f"{s},{float(v)!r}\n" for s, v in zip(SENSORS, y)))
    return tmp_path


def write_project(folder: Path, model: str, name: str = "p.toml", **kw) -> Path:
    model = model.replace("{solver}", str(folder / "solver.py"))
    return _projects.write_project(folder, project_text(model, **kw), name=name)
