"""Benchmarks of the simulators room (issue 14), each measured side by side in one run.

1. A stand-in solver sleeping 50 ms: 2 workers against 1 (target >= 1.8x on 2 cores).
2. Overhead per external run with a no-op solver (`cp`): work folder, template,
   fork/exec, parse, clean-up (target < 10 ms), beside a bare fork/exec of `cp`.
3. `edmf-rs run` twice, the second after changing one uncertainty source: model
   evaluations (target 0) and time against the first run (target < 10 %).
4. A Python model that wraps an FE program (the OpenSeesPy girder, ~3 ms per
   instance): 2 spawned worker processes against 1, batches of 256.

Run: python benches/simulators.py [--n 40] > benches/results-simulators.txt
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from edmf_rs import Project
from edmf_rs.simulators import CommandModel, CommandSpec, Evaluator

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the project-folder builder the tests use
from _projects import project_text, write_project  # noqa: E402

SLEEP = 0.05
SENSORS = ("S1", "S2")


def cpu_model() -> str:
    out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
    return next((line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("Model name")), "?")


def stand_in(folder: Path, sleep: float) -> CommandSpec:
    """A shell solver: sleeps, then writes results.csv from its deck."""
    (folder / "deck.csv").write_text("sensor,value\nS1,{a}\nS2,{b}\n")
    command = ("/bin/sh", "-c", f"sleep {sleep} && cp deck.csv results.csv") if sleep else ("cp", "deck.csv", "results.csv")
    return CommandSpec(command, ("deck.csv",), "results.csv", None, folder)


def time_evaluator(spec: CommandSpec, theta: np.ndarray, workers: int, root: Path) -> float:
    ev = Evaluator(("a", "b"), SENSORS, len(theta), command=CommandModel(spec, ("a", "b"), SENSORS),
                   workers=workers, out=root, store=False)
    start = time.perf_counter()
    out = ev(theta)
    elapsed = time.perf_counter() - start
    ev.close()
    assert np.array_equal(out, theta) and not ev.failures
    return elapsed


def workers_ratio(n: int, tmp: Path) -> None:
    spec = stand_in(tmp, SLEEP)
    theta = np.random.default_rng(0).uniform(size=(n, 2))
    t1 = time_evaluator(spec, theta, 1, tmp / "w1")
    t2 = time_evaluator(spec, theta, 2, tmp / "w2")
    print(f"[1] stand-in solver sleeping {SLEEP * 1e3:.0f} ms, {n} runs: 1 worker {t1:.2f} s "
          f"({t1 / n * 1e3:.1f} ms/run), 2 workers {t2:.2f} s ({t2 / n * 1e3:.1f} ms/run); "
          f"speed-up 2 vs 1 worker: {t1 / t2:.2f}x (target >= 1.8x)")


def overhead(n: int, tmp: Path, repeat: int = 3) -> None:
    """Best of ``repeat``, the two timings alternated so that load from elsewhere hits both alike."""
    spec = stand_in(tmp, 0)
    theta = np.random.default_rng(1).uniform(size=(n, 2))
    (tmp / "bare").mkdir()
    (tmp / "bare" / "deck.csv").write_text("sensor,value\nS1,1\nS2,2\n")
    ours, bare = [], []
    for k in range(repeat):
        ours.append(time_evaluator(spec, theta, 1, tmp / f"noop{k}") / n)
        start = time.perf_counter()
        for _ in range(n):
            subprocess.run(["cp", "deck.csv", "results.csv"], cwd=tmp / "bare", check=True)
        bare.append((time.perf_counter() - start) / n)
    t, b = min(ours), min(bare)
    print(f"[2] no-op solver (cp), {n} runs, 1 worker, best of {repeat}: {t * 1e3:.2f} ms per run (target < 10 ms); "
          f"a bare subprocess.run of cp: {b * 1e3:.2f} ms; edmf_rs's own part (folder, template, stdout/stderr "
          f"files, parse; clean-up in the background): {(t - b) * 1e3:.2f} ms")


def rerun(n: int, tmp: Path) -> None:
    folder = tmp / "project"
    folder.mkdir()
    (folder / "deck.csv").write_text("sensor,value\nS1,{a}\nS2,{b}\n")
    (folder / "meas.csv").write_text("sensor,value\nS1,0.5\nS2,0.5\n")
    out = folder / "out"
    times, evaluations = [], []
    for sd in (0.1, 0.2):
        text = project_text(
            identification={"phi": 0.95}, parameters={"a": (0.0, 1.0), "b": (0.0, 1.0)},
            sampling={"method": "sobol", "n": n},
            model={"command": ["/bin/sh", "-c", f"sleep {SLEEP} && cp deck.csv results.csv"], "files": ["deck.csv"],
                   "workers": 2},
            measurements={"file": "meas.csv"},
            uncertainty=[{"name": "model", "kind": "model", "distribution": "normal", "sd": sd}])
        path = write_project(folder, text)
        start = time.perf_counter()
        ident = Project.from_toml(path).run(progress=False, out=out)
        times.append(time.perf_counter() - start)
        evaluations.append((ident.evaluation["model_evaluations"], ident.evaluation["reused_evaluations"]))
    print(f"[3] Project.run, {n} instances, 50 ms stand-in, 2 workers: first run {times[0]:.2f} s "
          f"(evaluated {evaluations[0][0]}); after changing one uncertainty source {times[1]:.3f} s "
          f"(evaluated {evaluations[1][0]}, reused {evaluations[1][1]}): {100 * times[1] / times[0]:.1f} % "
          f"of the first run's time (target: 0 evaluations, < 10 %)")


def python_pool(n: int) -> None:
    from edmf_rs.examples import girder_opensees

    rng = np.random.default_rng(2)
    theta = np.column_stack([rng.uniform(20e3, 50e3, n), 10 ** rng.uniform(10, 14, n), 10 ** rng.uniform(3, 7, n)])
    times = {}
    for workers in (1, 2):
        ev = Evaluator(("E", "K_rot", "k_h"), tuple(f"s{i}" for i in range(10)), n,
                       function=girder_opensees.predict, ref="edmf_rs.examples.girder_opensees:predict",
                       path=".", workers=workers)
        ev(theta[:2])  # start the workers (spawn, imports) outside the timing
        start = time.perf_counter()
        parts = [ev(theta[i:i + 256]) for i in range(0, n, 256)]
        times[workers] = time.perf_counter() - start
        ev.close()
        assert np.concatenate(parts).shape == (n, 10)
    print(f"[4] OpenSeesPy girder as a Python function, {n} instances in batches of 256: 1 process "
          f"{times[1]:.2f} s ({times[1] / n * 1e3:.2f} ms/instance), 2 spawned processes {times[2]:.2f} s; "
          f"speed-up {times[1] / times[2]:.2f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=40, help="runs per measurement (default: %(default)s)")
    args = parser.parse_args()
    print(f"edmf_rs simulators benchmark, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    print(f"CPU: {cpu_model()}; Python {platform.python_version()}")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        workers_ratio(args.n, tmp)
        overhead(5 * args.n, tmp)
        rerun(2 * args.n, tmp)
    python_pool(1024)


if __name__ == "__main__":
    main()
