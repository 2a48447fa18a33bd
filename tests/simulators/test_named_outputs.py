"""A Python model returning named columns (DataFrame, mapping, structured
array) in another order than the measurements gives exactly the candidates of
the same model returning a bare array in the measurements' order, on every
path: in process, `workers = 2` (spawned processes), and served from the
prediction store on a rerun (issue 12 part 1 through issue 14's evaluator)."""

import json
import textwrap

import numpy as np
import pandas as pd
import pytest
from conftest import write_project
from edmf_rs import cli

NAMED = textwrap.dedent("""
    import numpy as np
    import pandas as pd
    from lin_model import predict

    ORDER = [2, 0, 3, 1]              # S3, S1, S4, S2
    NAMES = ["S1", "S2", "S3", "S4"]

    def frame(theta):
        g = predict(theta)
        cols = {NAMES[j]: g[:, j] for j in ORDER}
        cols["strain_energy"] = g.sum(axis=1)    # an output no sensor uses
        return pd.DataFrame(cols)

    def mapping(theta):
        g = predict(theta)
        return {NAMES[j]: g[:, j].tolist() for j in ORDER}

    def structured(theta):
        g = predict(theta)
        out = np.zeros(len(g), dtype=[(NAMES[j], "f8") for j in ORDER])
        for j in ORDER:
            out[NAMES[j]] = g[:, j]
        return out

    def bare_shuffled(theta):          # no names: [model] sensors gives the order
        return predict(theta)[:, ORDER]

    def without_s2(theta):
        g = predict(theta)
        return pd.DataFrame({"S4": g[:, 3], "S1": g[:, 0], "S3": g[:, 2]})
""")


def run(project, out, *extra):
    code = cli.main(["run", str(project), "--out", str(out), "--no-progress", *extra])
    return code, (json.loads((out / "summary.json").read_text()) if code == 0 else None)


@pytest.fixture
def named(folder):
    (folder / "named_model.py").write_text(NAMED)
    return folder


@pytest.mark.parametrize("function", ["frame", "mapping", "structured"])
def test_shuffled_named_columns_give_the_unshuffled_candidates_via_workers_and_the_store(named, tmp_path, function):
    bare = write_project(named, 'function = "lin_model:predict"\nbatch_size = 50', n=256, name="bare.toml")
    code, want = run(bare, tmp_path / "bare")
    assert code == 0 and want["candidates"] > 0
    expected = pd.read_parquet(tmp_path / "bare" / "candidates.parquet")
    project = write_project(named, f'function = "named_model:{function}"\nbatch_size = 50', n=256)
    for label, extra in (("two", ("--workers", "2")), ("one", ())):
        out = tmp_path / label
        code, got = run(project, out, *extra)
        assert code == 0 and (got["model_evaluations"], got["reused_evaluations"]) == (256, 0)
        assert got["candidates"] == want["candidates"]
        pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"), expected)
        # The rerun reads every prediction back from the store, columns by name.
        code, again = run(project, out, *extra)
        assert code == 0 and (again["model_evaluations"], again["reused_evaluations"]) == (0, 256)
        assert again["identification"]["sensor_mapping"] == got["identification"]["sensor_mapping"]
        assert got["identification"]["sensor_mapping"]["how"] == "by name"
        pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"), expected)


def test_the_report_shows_the_mapping_by_name(named, tmp_path):
    project = write_project(named, 'function = "named_model:frame"\nworkers = 2\nbatch_size = 64', n=64)
    code, summary = run(project, tmp_path / "out")
    assert code == 0
    text = json.dumps(summary)
    assert '"how": "by name"' in text and "strain_energy" in text  # the ignored output is listed


def test_a_sensor_missing_from_the_named_output_is_an_error_naming_both_sides(named, tmp_path, capsys):
    project = write_project(named, 'function = "named_model:without_s2"\nworkers = 2\nbatch_size = 16', n=32)
    code, _ = run(project, tmp_path / "out")
    assert code == 2
    err = capsys.readouterr().err
    assert "provides no prediction for sensor S2" in err and "S4, S1, S3" in err and "model.function" in err


def test_an_excluded_sensor_the_model_omits_is_stored_absent_and_refused_once_included(named, tmp_path, capsys):
    out = tmp_path / "out"
    model = 'function = "named_model:without_s2"\nbatch_size = 16'
    code, first = run(write_project(named, model, n=32, exclude=["S2"]), out)
    assert code == 0 and first["model_evaluations"] == 32
    bare = write_project(named, 'function = "lin_model:predict"', n=32, exclude=["S2"], name="bare.toml")
    assert run(bare, tmp_path / "bare")[1]["candidates"] == first["candidates"]
    code, again = run(write_project(named, model, n=32, exclude=["S2"]), out)  # still excluded: reused
    assert code == 0 and again["model_evaluations"] == 0
    capsys.readouterr()
    # S2 used now: the store never had it. (With one worker, the check on two instances before the
    # run refuses it already; with two, the model runs only in the workers, so the store must refuse.)
    code, _ = run(write_project(named, model, n=32), out, "--workers", "2")
    assert code == 2
    err = capsys.readouterr().err
    assert "provides no prediction for sensor S2" in err and "in the prediction store" in err
    assert len(list(out.glob("store/*/part-*.parquet"))) == 2  # nothing evaluated or stored again


def test_a_bare_array_in_model_sensors_order_is_stored_under_the_right_names(named, tmp_path):
    bare = write_project(named, 'function = "lin_model:predict"\nbatch_size = 50', n=128, name="bare.toml")
    want = run(bare, tmp_path / "bare")[1]
    expected = pd.read_parquet(tmp_path / "bare" / "candidates.parquet")
    model = 'function = "named_model:bare_shuffled"\nsensors = ["S3", "S1", "S4", "S2"]\nbatch_size = 50'
    project = write_project(named, model, n=128)
    out = tmp_path / "out"
    for extra, evaluations in ((("--workers", "2"), 128), ((), 0)):
        code, got = run(project, out, *extra)
        assert code == 0 and got["model_evaluations"] == evaluations and got["candidates"] == want["candidates"]
        pd.testing.assert_frame_equal(pd.read_parquet(out / "candidates.parquet"), expected)
    # The store's columns carry the sensors' names, whatever order the model used.
    stored = pd.concat(pd.read_parquet(f) for f in sorted(out.glob("store/*/part-*.parquet")))
    theta = stored[["p:a", "p:b"]].to_numpy()
    from conftest import A
    np.testing.assert_array_equal(stored[["s:S1", "s:S2", "s:S3", "s:S4"]].to_numpy(),
                                  theta[:, 0:1] * A[0] + theta[:, 1:2] * A[1])


def test_complex_outputs_from_workers_are_refused_not_cast():
    # What a worker sends back keeps its complex dtype, and the store's columns refuse it
    # (np.asarray(..., float64) kept the real part with a ComplexWarning only).
    from edmf_rs.simulators.columns import OutputMismatch, StoreColumns, portable

    out = portable(np.ones((1, 2)) + 0.5j)
    assert out.dtype == np.complex128
    with pytest.raises(OutputMismatch, match=r"m: returned ndarray of dtype complex128, expected an array of real "
                                             r"numbers of shape \(1, 2\)"):
        StoreColumns(("A", "B"), where="m")(out, 1, first=0)
    values, absent = StoreColumns(("A", "B"), where="m")(portable([[1, 2]]), 1, first=0)
    assert values.tolist() == [[1.0, 2.0]] and absent == ()
