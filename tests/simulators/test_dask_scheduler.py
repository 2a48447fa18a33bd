"""[compute] scheduler / --scheduler: a Python model evaluated on a Dask cluster
gives exactly the local run (candidates, summary, prediction store), and a
scheduler that cannot be reached is refused naming the address and the file."""

import json
import socket

import pandas as pd
import pytest
from conftest import write_project
from distributed import LocalCluster
from edmf_rs import cli

NAMED = """
import pandas as pd
from lin_model import predict

def frame(theta):
    g = predict(theta)
    return pd.DataFrame({"S4": g[:, 3], "S2": g[:, 1], "S1": g[:, 0], "S3": g[:, 2]})
"""

#: summary.json fields that measure time, not the result.
TIMING = ("elapsed_seconds", "seconds", "elapsed")


def run(project, out, *extra):
    code = cli.main(["run", str(project), "--out", str(out), "--no-progress", *extra])
    return code, (json.loads((out / "summary.json").read_text()) if code == 0 else None)


def without_timing(summary):
    return {k: v for k, v in summary.items() if k not in TIMING and "second" not in k}


@pytest.fixture(scope="module")
def cluster():
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None) as c:
        yield c


@pytest.mark.parametrize("function", ["lin_model:predict", "named:frame"])
def test_a_run_on_a_dask_cluster_equals_the_local_run(folder, tmp_path, cluster, function):
    (folder / "named.py").write_text(NAMED)
    model = f'function = "{function}"\nbatch_size = 40'
    local = write_project(folder, model, n=200, name="local.toml")
    code, want = run(local, tmp_path / "local")
    assert code == 0 and want["candidates"] > 0
    on_cluster = write_project(folder, model, n=200, name="cluster.toml")
    on_cluster.write_text(on_cluster.read_text() + f'\n[compute]\nscheduler = "{cluster.scheduler_address}"\n')
    out = tmp_path / "cluster"
    code, got = run(on_cluster, out)
    assert code == 0
    assert (got["model_evaluations"], got["reused_evaluations"], got["failed_instances"]) == (200, 0, 0)
    assert without_timing(got) == without_timing(want) | {"project": got["project"]}
    pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "local" / "candidates.parquet"))
    # The store written through the cluster serves a local rerun: nothing is evaluated again.
    code, again = run(local, out, "--force")
    assert code == 0 and (again["model_evaluations"], again["reused_evaluations"]) == (0, 200)
    pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "local" / "candidates.parquet"))


def test_the_command_line_option_gives_the_scheduler(folder, tmp_path, cluster):
    project = write_project(folder, 'function = "lin_model:predict"\nbatch_size = 40', n=120)
    code, want = run(project, tmp_path / "local")
    code, got = run(project, tmp_path / "cluster", "--scheduler", cluster.scheduler_address)
    assert code == 0 and got["candidates"] == want["candidates"] and got["model_evaluations"] == 120
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "cluster" / "candidates.parquet"),
                                  pd.read_parquet(tmp_path / "local" / "candidates.parquet"))


def test_an_unreachable_scheduler_exits_2_naming_the_address_and_the_project_file(folder, tmp_path, capsys):
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    project = write_project(folder, 'function = "lin_model:predict"', n=16)
    project.write_text(project.read_text() + f'\n[compute]\nscheduler = "{address}"\n')
    code, _ = run(project, tmp_path / "out")
    assert code == 2
    err = capsys.readouterr().err
    assert address in err and str(project) in err and "compute.scheduler" in err


def test_a_scheduler_with_an_external_program_is_refused(folder, tmp_path, capsys):
    from conftest import command_model

    project = write_project(folder, command_model(), n=16)
    project.write_text(project.read_text() + '\n[compute]\nscheduler = "tcp://127.0.0.1:8786"\n')
    code, _ = run(project, tmp_path / "out")
    assert code == 2
    assert "compute.scheduler" in capsys.readouterr().err
