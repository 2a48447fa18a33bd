"""Errors that say where they come from (issue 12, part 6): the project's code
failing is exit 1 and named, a bad project is exit 2, checks before the run."""

import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest
from edmf_rs import cli
from edmf_rs.project import Project, ProjectError
from edmf_rs.project.errors import UserCodeError
from edmf_rs.project.plan import RunTooLarge

from _projects import project_text, write_project

MODEL = textwrap.dedent("""
    import sys
    from pathlib import Path
    import numpy as np

    def fine(theta):
        return np.column_stack([theta[:, 0], theta[:, 1]])

    def boom(theta):
        if (theta[:, 0] > 1.5).any():
            bad = theta[theta[:, 0] > 1.5][0]
            raise ZeroDivisionError(f"cannot model a = {bad[0]}")
        return fine(theta)

    def logged_wrong_shape(theta):
        with open(Path(__file__).with_name("calls.log"), "a") as fh:
            fh.write(f"{len(theta)}\\n")
        return theta[:, :1]

    def quits(theta):
        if theta[0, 0] > 0.5:
            sys.exit(0)
        return fine(theta)

    def hard_quits(theta):
        if theta[0, 0] > 0.5:
            import os
            os._exit(0)
        return fine(theta)

    def _square(x):
        return x * x

    def forks(theta):
        # a model that uses multiprocessing's fork start method: its children end with os._exit
        import multiprocessing
        with multiprocessing.get_context("fork").Pool(2) as pool:
            squares = pool.map(_square, [float(t) for t in theta[:, 1]])
        return np.column_stack([theta[:, 0], np.sqrt(squares)])

    def overflows(theta):
        out = fine(theta)
        out[theta[:, 0] > 1.5, 1] = np.inf
        return out

    def edits(theta):
        theta[:, 0] = 0.0
        return fine(theta)

    def q_fails(theta):
        if (theta[:, 0] > 0.5).any():
            raise RuntimeError("no load case")
        return theta[:, 0]

    def complex_out(theta):
        return fine(theta) + 0.5j

    def q_complex(theta):
        return theta[:, 0] + 1j

    def q_wrong(theta):
        return np.zeros((len(theta), 2))
""")
PROJECT = project_text(parameters={"a": (0.0, 2.0), "b": (0.0, 2.0)},
                       sampling={"method": "grid", "points": {"a": 21, "b": 21}},
                       model={"function": "m:FUNC", "batch_size": 100}, measurements={"file": "meas.csv"},
                       uncertainty=[{"name": "noise", "kind": "measurement", "distribution": "normal", "sd": 0.5}])


def project(tmp_path: Path, func: str = "fine", extra: str = "") -> Path:
    return write_project(tmp_path, PROJECT.replace("FUNC", func) + extra, modules={"m": MODEL},
                         csv="sensor,value\nS1,1.0\nS2,1.0\n")


def run(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "edmf_rs", *map(str, args)], capture_output=True, text=True)


def test_model_exception_is_exit_1_naming_batch_instances_and_parameters(tmp_path):
    path = project(tmp_path, "boom")
    proc = run("run", path, "--out", tmp_path / "out", "--no-progress")
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    message = proc.stderr.strip().splitlines()[-1]
    assert message.startswith(f"edmf-rs: error: {path}: model.function = 'm:boom' raised ZeroDivisionError: "
                              "cannot model a = 1.6"), message
    # grid in C order: a = 1.6 first at instance 16 * 21 = 336, in batch 3 (300..399)
    assert "on batch 3 (instances 300..399); first failing instance: 336 (a=1.6, b=0)" in message
    assert not (tmp_path / "out" / "summary.json").exists()
    proc = run("run", path, "--out", tmp_path / "out", "--no-progress", "--traceback")
    assert proc.returncode == 1 and "Traceback" in proc.stderr and "ZeroDivisionError" in proc.stderr


def test_sys_exit_in_the_model_is_a_failure(tmp_path):
    proc = run("run", project(tmp_path, "quits"), "--out", tmp_path / "out", "--no-progress")
    assert proc.returncode == 1
    assert "model.function = 'm:quits' called sys.exit(0)" in proc.stderr
    assert not (tmp_path / "out" / "summary.json").exists()


# The model exits when the first row of its call has a > 0.5 (grid in C order: instance 21 i + j has
# a = 0.1 i, b = 0.1 j). One worker gets whole batches: batch 2 starts at 200 (a = 0.9, b = 1.1). Two workers
# get halves: batch 1's second half starts at 150 (a = 0.7); alone, instance 126 (a = 0.6, b = 0) fails first.
@pytest.mark.parametrize("workers, where", [
    (1, "on batch 2 (instances 200..299); first failing instance: 200 (a=0.9, b=1.1)"),
    (2, "on batch 1 (instances 100..199); first failing instance: 126 (a=0.6, b=0)")])
def test_os_exit_in_the_model_is_a_failure(tmp_path, workers, where):
    # os._exit(0) ended the interpreter at once: exit status 0 and no outputs, as if the run had passed
    text = PROJECT.replace("FUNC", "hard_quits").replace('batch_size = 100', f'batch_size = 100\nworkers = {workers}')
    path = write_project(tmp_path, text, modules={"m": MODEL}, csv="sensor,value\nS1,1.0\nS2,1.0\n")
    proc = run("run", path, "--out", tmp_path / "out", "--no-progress")
    assert proc.returncode == 1, proc.stderr
    message = proc.stderr.strip().splitlines()[-1]
    assert f"model.function = 'm:hard_quits' called os._exit(0), {where}" in message, message
    assert not (tmp_path / "out" / "summary.json").exists()


def test_a_model_whose_forked_children_exit_runs_as_usual(tmp_path):
    # the refusal holds in edmf_rs's own process only: multiprocessing's forked children must still exit
    forked = run("run", project(tmp_path / "forks", "forks"), "--out", tmp_path / "forks" / "out", "--no-progress")
    plain = run("run", project(tmp_path / "fine", "fine"), "--out", tmp_path / "fine" / "out", "--no-progress")
    assert forked.returncode == 0 and plain.returncode == 0, forked.stderr + plain.stderr
    read = lambda folder: pd.read_parquet(folder / "out" / "candidates.parquet")
    assert len(read(tmp_path / "fine")) > 0
    pd.testing.assert_frame_equal(read(tmp_path / "forks"), read(tmp_path / "fine"))


def test_an_infinite_prediction_is_refused_like_nan(tmp_path):
    proc = run("run", project(tmp_path, "overflows"), "--out", tmp_path / "out", "--no-progress")
    assert proc.returncode == 2, proc.stderr
    assert "model.function = 'm:overflows': returned inf for instance 336 (a=1.6, b=0); expected finite " \
           "predictions" in proc.stderr


def test_prognosis_failure_names_the_prognosis(tmp_path):
    extra = '\n[[prognosis]]\nname = "q"\nfunction = "m:q_fails"\n'
    with pytest.raises(UserCodeError, match=r"prognosis\[0\]\.function = 'm:q_fails' raised RuntimeError: no load "
                                            r"case, on \d+ candidates; first failing candidate: \d+ \(a="):
        Project.from_toml(project(tmp_path, "fine", extra)).run(progress=False)


def test_the_model_is_checked_on_two_instances_before_the_run(tmp_path):
    path = project(tmp_path, "logged_wrong_shape")
    proc = run("run", path, "--out", tmp_path / "out", "--no-progress")
    assert proc.returncode == 2
    assert "returned shape (2, 1) for 2 parameter sets, expected (2, 2)" in proc.stderr
    assert (tmp_path / "calls.log").read_text().split() == ["2"]  # never on a whole batch


def test_prognosis_shape_is_checked_before_the_run(tmp_path):
    extra = '\n[[prognosis]]\nname = "q"\nfunction = "m:q_wrong"\n'
    with pytest.raises(ProjectError, match=r"prognosis\[0\]\.function = 'm:q_wrong': returned shape \(2, 2\) for 2 "
                                           r"instances, expected \(2,\)"):
        Project.from_toml(project(tmp_path, "fine", extra)).check()


def test_a_complex_model_output_is_refused_not_cast_to_its_real_part(tmp_path):
    # It ran with exit 0 and the candidates of the real part (a ComplexWarning on stderr only),
    # where falsify_model refuses complex output.
    path = project(tmp_path, "complex_out")
    with pytest.raises(ProjectError, match="returned ndarray of dtype complex128, expected an array of real numbers"):
        Project.from_toml(path).check()  # in process, before the run
    proc = run("run", path, "--out", tmp_path / "out", "--no-progress")  # through the prediction store
    assert proc.returncode == 2
    assert "model.function = 'm:complex_out': returned ndarray of dtype complex128, expected an array of real " \
           "numbers" in proc.stderr
    assert not (tmp_path / "out" / "summary.json").exists()


def test_a_complex_prognosis_is_refused_not_cast_to_its_real_part(tmp_path):
    # It ran with exit 0 and the real part's range (a ComplexWarning on stderr only).
    extra = '\n[[prognosis]]\nname = "q"\nfunction = "m:q_complex"\n'
    with pytest.raises(ProjectError, match=r"function = 'm:q_complex': returned ndarray of dtype complex128, "
                                           r"expected one real number per instance"):
        Project.from_toml(project(tmp_path, "fine", extra)).check()


def test_a_model_editing_theta_in_place_fails_instead_of_corrupting(tmp_path):
    with pytest.raises(UserCodeError, match="read-only"):
        Project.from_toml(project(tmp_path, "edits")).run(progress=False)


def test_file_errors_name_the_project_file_and_the_folder(tmp_path):
    path = project(tmp_path)
    (tmp_path / "meas.csv").unlink()
    with pytest.raises(ProjectError) as err:
        Project.from_toml(path)
    assert str(err.value) == (f"{path}: measurements.file: no such file 'meas.csv' (looked in {tmp_path.resolve()})")
    with pytest.raises(ProjectError, match=r"no such project file \(looked in "):
        Project.from_toml(tmp_path / "nowhere.toml")


def test_oversized_grids_and_hypercubes_are_refused_with_the_count(tmp_path):
    huge = PROJECT.replace("points = { a = 21, b = 21 }", "points = { a = 10_000_000_000, b = 10_000_000_000 }")
    (tmp_path / "g.toml").write_text(huge)
    with pytest.raises(ProjectError, match=r"sampling\.points: the grid 10,000,000,000 x 10,000,000,000 has "
                                           r"100,000,000,000,000,000,000 instances, more than can be counted"):
        Project.from_toml(tmp_path / "g.toml")
    lhs = PROJECT.replace('method = "grid"\npoints = { a = 21, b = 21 }', 'method = "lhs"\nn = 1_000_000_000_000')
    (tmp_path / "l.toml").write_text(lhs)
    with pytest.raises(ProjectError, match=r"sampling\.n: a Latin hypercube of 1,000,000,000,000 instances is drawn "
                                           r"whole .*method = 'sobol'"):
        Project.from_toml(tmp_path / "l.toml")


def test_runs_over_the_limits_need_yes(tmp_path, capsys):
    path = project(tmp_path)
    path.write_text(path.read_text().replace("points = { a = 21, b = 21 }", "points = { a = 100_000, b = 1_000_000 }"))
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "100,000,000,000 model instances, more than 10,000,000,000; rerun with --yes" in err
    assert not (tmp_path / "out").exists()
    small = Project.from_toml(project(tmp_path))
    with pytest.raises(RunTooLarge, match=r"the run is estimated at .* \(441 instances; the first 100 took"):
        small.run(progress=False, max_seconds=1e-12)


def test_ctrl_c_while_the_command_imports_prints_one_line(tmp_path):
    script = textwrap.dedent("""
        import sys
        class Interrupt:
            def find_spec(self, name, path, target=None):
                if name == "edmf_rs.project":
                    raise KeyboardInterrupt
        sys.meta_path.insert(0, Interrupt())
        sys.argv[0] = "/usr/bin/edmf-rs"
        import edmf_rs
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert proc.stderr == "edmf-rs: interrupted\n"
    assert proc.returncode != 0


def test_exit_refusals_overlapping_in_threads_put_os_exit_back():
    # two threads inside at once, leaving in the order they entered: os._exit must be the real one after
    import os
    import threading

    from edmf_rs.simulators.exits import ExitCalled, exits_refused
    real, inside, first_out = os._exit, threading.Barrier(2), threading.Event()
    caught = []

    def worker(k):
        with exits_refused():
            inside.wait()
            try:
                os._exit(3)
            except ExitCalled as exc:
                caught.append(exc.code)
            if k == 1:  # the second one in leaves last
                first_out.wait(timeout=30)
        if k == 0:
            first_out.set()

    threads = [threading.Thread(target=worker, args=(k,)) for k in (0, 1)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=30)
    assert caught == [3, 3] and os._exit is real


def test_os_exit_in_another_thread_still_ends_the_process():
    # only the threads running the project's code are guarded: a watchdog's os._exit(3) must end the process
    script = textwrap.dedent("""
        import os, threading, time
        from edmf_rs.simulators.exits import exits_refused
        with exits_refused():
            threading.Thread(target=lambda: os._exit(3)).start()
            time.sleep(20)
        print("still running")
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 3 and "still running" not in proc.stdout, proc.stderr


@pytest.mark.parametrize("func, code, how", [("hard_quits", 0, "os._exit"), ("quits", 0, "sys.exit")])
def test_a_worker_sends_an_exit_back_as_an_ordinary_exception(tmp_path, func, code, how):
    # a SystemExit from a task makes Dask shut its worker down (KilledWorker, the exit never named)
    import numpy as np
    from edmf_rs.project.errors import call_user_code
    from edmf_rs.simulators.exits import ModelExited
    from edmf_rs.simulators.pool import _call
    project(tmp_path)  # writes m.py
    theta = np.array([[0.9, 0.2]])
    with pytest.raises(ModelExited) as info:
        _call(f"m:{func}", str(tmp_path), {}, theta)
    assert not isinstance(info.value, SystemExit) and info.value.code == code
    with pytest.raises(UserCodeError, match=rf"model.function = 'm:{func}' called {how}\({code}\), on batch 0"):
        call_user_code(lambda t: _call(f"m:{func}", str(tmp_path), {}, t), theta, what=f"model.function = 'm:{func}'",
                       where="batch 0", first=0, describe=str)


@pytest.mark.parametrize("statement, called", [("import sys; sys.exit(0)", "sys.exit(0)"),
                                               ("import os; os._exit(0)", "os._exit(0)")])
def test_a_model_module_that_exits_on_import_is_refused(tmp_path, statement, called):
    # was: exit status 0 and no outputs, the module's top level outside any guard
    path = write_project(tmp_path, PROJECT.replace("FUNC", "fine"), modules={"m": statement + "\n" + MODEL},
                         csv="sensor,value\nS1,1.0\nS2,1.0\n")
    proc = run("run", path, "--out", tmp_path / "out", "--no-progress")
    assert proc.returncode == 2, proc.stderr
    assert f"{path}: model.function: importing 'm' called {called}" in proc.stderr
    assert not (tmp_path / "out" / "summary.json").exists()
