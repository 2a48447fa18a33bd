"""Project files: validation messages, uncertainty sources, precomputed instances,
and `edmf-rs run` end to end on the shipped examples."""

import json
import math
import textwrap
from pathlib import Path

import edmf_rs
import numpy as np
import pandas as pd
import pytest
from edmf_rs import cli
from edmf_rs.project import Project, ProjectError
from scipy import stats

import _projects
from _projects import LINEAR_CSV, LINEAR_MODEL, project_text, uncertainty

EXAMPLES = Path(edmf_rs.__file__).parent / "examples" / "projects"

# The linear model g(a, b) = [a, b] @ A of four sensors; the truth is a = b = 1.
A = np.array([[1.0, 2.0, 0.5, -1.0], [0.3, -0.2, 1.5, 0.8]])
MODEL = LINEAR_MODEL + textwrap.dedent("""
    def nan_above(theta, limit=1.5):
        out = theta @ A
        out[theta[:, 0] > limit, 0] = np.nan
        return out
    not_callable = 3
""")
CSV = LINEAR_CSV
Y = np.array([1.3, 1.8, 2.0, -0.2])
TABLES = dict(identification={"name": "linear", "phi": 0.95}, parameters={"a": (0.0, 2.0), "b": (0.0, 2.0)},
              sampling={"method": "grid", "points": {"a": 21, "b": 21}}, model={"function": "lin_model:predict"},
              measurements={"file": "meas.csv"})
NOISE = uncertainty(name="noise", kind="measurement", distribution="normal", sd=0.4)
BASE = project_text(**TABLES) + uncertainty(name="model", kind="model", distribution="normal", mean=0.1, sd=0.3) + NOISE


def write_project(folder: Path, toml: str = BASE, csv: str = CSV, name: str = "lin.toml") -> Path:
    return _projects.write_project(folder, toml, modules={"lin_model": MODEL}, csv=csv, name=name)


def with_sources(*sources: str) -> str:
    """BASE with its [[uncertainty]] tables replaced by ``sources``."""
    return project_text(**TABLES) + "".join(sources)


# --- validation: one clear message naming the file and the key ------------------------------------

BAD = {
    "unknown key": (BASE.replace("low = 0.0\nhigh = 2.0\n\n[parameters.b]", "lwo = 0.0\nhigh = 2.0\n\n[parameters.b]"),
                    ["unknown key 'parameters.a.lwo'", "did you mean 'low'"]),
    "unknown table": (BASE + "\n[output]\ndir = 'x'\n", ["unknown key 'output'"]),
    "missing bound": (BASE.replace("[parameters.b]\nlow = 0.0\n", "[parameters.b]\n"),
                      ["parameters.b.low", "expected the lower bound", "missing"]),
    "low >= high": (BASE.replace("[parameters.b]\nlow = 0.0", "[parameters.b]\nlow = 3.0"),
                    ["parameters.b.low", "expected low < high"]),
    "bound not a number": (BASE.replace("high = 2.0\n\n[sampling]", "high = \"2\"\n\n[sampling]"),
                           ["parameters.b.high", "a number", "got '2'"]),
    "log with low <= 0": (BASE.replace("[parameters.b]\nlow = 0.0\nhigh = 2.0", "[parameters.b]\nlow = 0.0\nhigh = 2.0\nscale = \"log\""),
                          ["parameters.b.low", "low > 0"]),
    "grid point missing": (BASE.replace("points = { a = 21, b = 21 }", "points = { a = 21 }"), ["sampling.points.b", "missing"]),
    "lhs without n": (BASE.replace("method = \"grid\"\npoints = { a = 21, b = 21 }", "method = \"lhs\""), ["sampling.n", "missing"]),
    "bad method": (BASE.replace("method = \"grid\"", "method = \"random\""), ["sampling.method", "'grid', 'lhs', 'sobol'"]),
    "phi": (BASE.replace("phi = 0.95", "phi = 1.5"), ["identification.phi", "between 0.5 and 0.999999999"]),
    "correction": (BASE.replace("phi = 0.95", "correction = \"holm\""), ["identification.correction", "'sidak'"]),
    "no model": (BASE.replace("function = \"lin_model:predict\"", ""), ["model.function", "predictions"]),
    "module missing": (BASE.replace("lin_model:predict", "nowhere_model:predict"), ["model.function", "cannot import module 'nowhere_model'"]),
    "function missing": (BASE.replace("lin_model:predict", "lin_model:nothing"), ["model.function", "has no 'nothing'"]),
    "not callable": (BASE.replace("lin_model:predict", "lin_model:not_callable"), ["model.function", "not callable"]),
    "bad ref": (BASE.replace("lin_model:predict", "lin_model.predict"), ["model.function", "'module:function'"]),
    "unknown sensor": (with_sources(uncertainty(name="n", kind="measurement", distribution="normal", sd=0.1, sensors=["S1", "S9"])),
                       ["uncertainty[0].sensors", "'S9' is not in the measurements"]),
    "unknown type": (with_sources(uncertainty(name="n", kind="measurement", distribution="normal", sd=0.1, sensors={"type": "tilt"})),
                     ["uncertainty[0].sensors", "deflection, strain", "'tilt'"]),
    "uncovered sensor": (with_sources(uncertainty(name="n", kind="measurement", distribution="normal", sd=0.1, sensors=["S1", "S2", "S3"])),
                         ["sensor 'S4' is covered by no [[uncertainty]] source"]),
    "sd <= 0": (with_sources(uncertainty(name="n", kind="measurement", distribution="normal", sd=0.0)),
                ["uncertainty[0].sd", "standard deviation > 0"]),
    "uniform with sd": (with_sources(uncertainty(name="n", kind="model", distribution="uniform", low=0.0, high=1.0, sd=2.0)),
                        ["uncertainty[0].sd", "no sd for a uniform distribution"]),
    "uniform low >= high": (with_sources(uncertainty(name="n", kind="model", distribution="uniform", low=1.0, high=1.0)),
                            ["uncertainty[0].high", "above low"]),
    "bad kind": (with_sources(uncertainty(name="n", kind="sensor", distribution="normal", sd=1.0)), ["uncertainty[0].kind", "'model', 'measurement'"]),
    "no uncertainty": (with_sources(), ["uncertainty", "at least one [[uncertainty]]"]),
    "exclude unknown": (BASE.replace("file = \"meas.csv\"", "file = \"meas.csv\"\nexclude = [\"S7\"]"), ["measurements.exclude", "unknown sensor 'S7'"]),
    "toml syntax": (BASE.replace("phi = 0.95", "phi = = 0.95"), ["invalid TOML", "line 4"]),
    "bad scale": (BASE.replace("[parameters.b]\nlow = 0.0\nhigh = 2.0", "[parameters.b]\nlow = 0.0\nhigh = 2.0\nscale = \"ln\""),
                  ["parameters.b.scale: expected one of 'linear', 'log', got 'ln'"]),
    # A negative seed passed validation and then failed in numpy, naming neither file nor key.
    "negative sampling seed": (BASE.replace("method = \"grid\"\npoints = { a = 21, b = 21 }", "method = \"lhs\"\nn = 10\nseed = -1"),
                               ["sampling.seed: expected a random seed, an integer >= 0, got -1"]),
    "negative identification seed": (BASE.replace("phi = 0.95", "phi = 0.95\nseed = -1"),
                                     ["identification.seed: expected a random seed, an integer >= 0, got -1"]),
    "negative adaptive seed": (BASE.replace("method = \"grid\"\npoints = { a = 21, b = 21 }", "method = \"adaptive\"\nbudget = 60\nseed = -1"),
                               ["sampling.seed: expected a random seed, an integer >= 0, got -1"]),
    "seed not an integer": (BASE.replace("phi = 0.95", "phi = 0.95\nseed = true"),
                            ["identification.seed: expected a random seed, an integer >= 0, got True"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_project_gives_one_clear_message(tmp_path, case):
    toml, fragments = BAD[case]
    path = write_project(tmp_path, toml)
    with pytest.raises(ProjectError) as err:
        Project.from_toml(path)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and message.count(path.name) == 1, message  # named once
    for fragment in fragments:
        assert fragment in message, message


@pytest.mark.parametrize("csv, fragments", [
    ("sensor,value\nS1,1.3\nS2,abc\nS3,2\nS4,1\n", ["meas.csv: line 3: value", "'abc'"]),
    ("name,value\nS1,1.3\n", ["meas.csv: line 1", "missing sensor"]),
    ("sensor,value\nS1,1.3\nS1,1.8\nS3,2\nS4,1\n", ["sensor 'S1' appears twice"]),
])
def test_bad_measurements_name_file_and_line(tmp_path, csv, fragments):
    with pytest.raises(ProjectError) as err:
        Project.from_toml(write_project(tmp_path, csv=csv))
    for fragment in fragments:
        assert fragment in str(err.value)


def test_model_returning_the_wrong_shape_or_nan(tmp_path):
    project = Project.from_toml(write_project(tmp_path, BASE.replace("lin_model:predict", "lin_model:three_columns")))
    with pytest.raises(ProjectError, match=r"lin\.toml: model\.function = 'lin_model:three_columns': returned shape "
                                           r"\(441, 3\) for 441 parameter sets, expected \(441, 4\)"):
        project.run(progress=False)
    project = Project.from_toml(write_project(tmp_path, BASE.replace("lin_model:predict", "lin_model:nan_above")))
    with pytest.raises(ProjectError, match=r"returned NaN for instance 336 \(a=1\.6, b=0\)"):
        project.run(progress=False)
    falsify_nan = BASE.replace("lin_model:predict", "lin_model:nan_above").replace("[model]", "[model]\nnan = \"falsify\"")
    ident = Project.from_toml(write_project(tmp_path, falsify_nan)).run(progress=False)
    assert ident.falsification.n_invalid == 5 * 21  # a in {1.6, 1.7, 1.8, 1.9, 2.0}


# --- uncertainty sources ----------------------------------------------------------------------------

def combined(tmp_path, *sources):
    return Project.from_toml(write_project(tmp_path, with_sources(*sources))).combined_uncertainty()


def test_normal_absolute_all_sensors_is_exact(tmp_path):
    c = combined(tmp_path, uncertainty(name="m", kind="model", distribution="normal", mean=0.1, sd=0.3), NOISE)
    assert c.exact
    np.testing.assert_allclose(c.mean, 0.1)
    np.testing.assert_allclose(c.std, 0.5)  # sqrt(0.3^2 + 0.4^2)


def test_normal_relative_to_measured(tmp_path):
    c = combined(tmp_path, uncertainty(name="m", kind="model", distribution="normal", mean=-0.1, sd=0.2,
                                       relative_to="measured"), NOISE)
    np.testing.assert_allclose(c.mean, -0.1 * Y)
    np.testing.assert_allclose(c.std, np.sqrt((0.2 * Y) ** 2 + 0.4**2))


def test_sources_on_a_list_or_a_type_add_nothing_elsewhere(tmp_path):
    c = combined(tmp_path, uncertainty(name="m", kind="model", distribution="normal", mean=0.2, sd=0.3,
                                       sensors={"type": "strain"}),
                 uncertainty(name="s1", kind="measurement", distribution="normal", mean=0.05, sd=1.2, sensors=["S1"]),
                 NOISE)
    np.testing.assert_allclose(c.mean, [-0.05, 0.0, 0.2, 0.2])
    np.testing.assert_allclose(c.std, [math.hypot(1.2, 0.4), 0.4, 0.5, 0.5])


def test_uniform_absolute_gives_monte_carlo(tmp_path):
    c = combined(tmp_path, uncertainty(name="m", kind="model", distribution="uniform", low=-0.3, high=0.6, sensors=["S1", "S2"]),
                 NOISE)
    assert not c.exact and c.samples.shape == (200_000, 4)
    np.testing.assert_allclose(c.mean, [0.15, 0.15, 0.0, 0.0], atol=0.005)
    np.testing.assert_allclose(c.std, [math.sqrt(0.9**2 / 12 + 0.16)] * 2 + [0.4] * 2, rtol=0.01)


def test_uniform_relative_to_measured_spans_the_fractions(tmp_path):
    c = combined(tmp_path, uncertainty(name="m", kind="model", distribution="uniform", low=-0.1, high=0.2,
                                       relative_to="measured"),
                 uncertainty(name="tiny", kind="measurement", distribution="normal", sd=1e-6))
    # fraction * y: [-0.1 y, 0.2 y] for y > 0 and [0.2 y, -0.1 y] for y < 0
    low = np.minimum(-0.1 * Y, 0.2 * Y)
    high = np.maximum(-0.1 * Y, 0.2 * Y)
    np.testing.assert_allclose(c.samples.min(axis=0), low, atol=1e-4)
    np.testing.assert_allclose(c.samples.max(axis=0), high, atol=1e-4)


def test_monte_carlo_is_reproducible_with_the_seed(tmp_path):
    src = uncertainty(name="m", kind="model", distribution="uniform", low=-0.3, high=0.6)
    a, b = combined(tmp_path / "a", src, NOISE), combined(tmp_path / "b", src, NOISE)
    np.testing.assert_array_equal(a.samples, b.samples)


# --- runs: candidates, exclusion, precomputed instances ----------------------------------------------

def brute_force_candidates(exclude=()):
    """Candidates of the BASE project by hand: grid, g = theta @ A, U_c ~ N(0.1, 0.5), Sidak (Eq. 5, 6, 8)."""
    a, b = np.meshgrid(np.linspace(0, 2, 21), np.linspace(0, 2, 21), indexing="ij")
    theta = np.column_stack([a.ravel(), b.ravel()])
    keep = [j for j in range(4) if f"S{j + 1}" not in exclude]
    r = (theta @ A - Y)[:, keep]
    z = stats.norm.ppf(1 - (1 - 0.95 ** (1 / len(keep))) / 2)
    inside = np.all(np.abs(r - 0.1) <= 0.5 * z, axis=1)
    return np.flatnonzero(inside), theta


def test_run_matches_brute_force_and_exclusion(tmp_path):
    ident = Project.from_toml(write_project(tmp_path)).run(progress=False)
    expected, theta = brute_force_candidates()
    assert 0 < expected.size < 441
    np.testing.assert_array_equal(ident.candidates.index.to_numpy(), expected)
    assert list(ident.candidates.columns) == ["a", "b", "S1", "S2", "S3", "S4"]
    np.testing.assert_allclose(ident.candidates[["a", "b"]].to_numpy(), theta[expected])
    excluded = Project.from_toml(write_project(tmp_path, BASE.replace('file = "meas.csv"', 'file = "meas.csv"\nexclude = ["S2"]')))
    ident = excluded.run(progress=False)
    assert excluded.sensor_names == ("S1", "S3", "S4")
    np.testing.assert_array_equal(ident.candidates.index.to_numpy(), brute_force_candidates(exclude=("S2",))[0])


@pytest.mark.parametrize("table", ["measurements.sensors", "sensors"])
def test_inline_sensors_and_model_options(tmp_path, table):
    sensors = "".join(f'[[{table}]]\nname = "S{j + 1}"\nvalue = {v}\n' for j, v in enumerate(Y))
    toml = BASE.replace('[measurements]\nfile = "meas.csv"\n', sensors).replace(
        'function = "lin_model:predict"', 'function = "lin_model:predict"\noptions = { scale = 2.0 }')
    ident = Project.from_toml(write_project(tmp_path, toml)).run(progress=False)
    np.testing.assert_allclose(ident.candidates[["S1", "S2", "S3", "S4"]].to_numpy(),
                               2.0 * ident.candidates[["a", "b"]].to_numpy() @ A)


@pytest.mark.parametrize("suffix", [".npy", ".csv", ".parquet"])
def test_precomputed_instances_match_the_function(tmp_path, suffix):
    _, theta = brute_force_candidates()
    predictions = theta @ A
    params = pd.DataFrame(theta, columns=["a", "b"])
    preds = pd.DataFrame(predictions, columns=["S1", "S2", "S3", "S4"])[["S3", "S1", "S4", "S2"]]  # any order
    if suffix == ".npy":
        np.save(tmp_path / "theta.npy", theta)
        np.save(tmp_path / "g.npy", predictions)
    elif suffix == ".csv":
        params.to_csv(tmp_path / "theta.csv", index=False)
        preds.to_csv(tmp_path / "g.csv", index=False)
    else:
        params.to_parquet(tmp_path / "theta.parquet")
        preds.to_parquet(tmp_path / "g.parquet")
    toml = BASE.replace('[sampling]\nmethod = "grid"\npoints = { a = 21, b = 21 }\n', "").replace(
        'function = "lin_model:predict"', f'predictions = "g{suffix}"\nparameters = "theta{suffix}"')
    ident = Project.from_toml(write_project(tmp_path, toml)).run(progress=False)
    np.testing.assert_array_equal(ident.candidates.index.to_numpy(), brute_force_candidates()[0])
    assert ident.summary_dict()["sampling"]["method"] == "precomputed"


def test_precomputed_columns_must_match_the_sensors(tmp_path):
    _, theta = brute_force_candidates()
    pd.DataFrame(theta, columns=["a", "b"]).to_csv(tmp_path / "theta.csv", index=False)
    pd.DataFrame(theta @ A, columns=["S1", "S2", "S3", "X4"]).to_csv(tmp_path / "g.csv", index=False)
    np.save(tmp_path / "g3.npy", (theta @ A)[:, :3])
    toml = BASE.replace('[sampling]\nmethod = "grid"\npoints = { a = 21, b = 21 }\n', "").replace(
        'function = "lin_model:predict"', 'predictions = "g.csv"\nparameters = "theta.csv"')
    with pytest.raises(ProjectError, match=r"g\.csv: expected columns named after the sensors \(S1, S2, S3, S4\), "
                                           r"missing S4 \(the file also has X4\)"):
        Project.from_toml(write_project(tmp_path, toml))
    with pytest.raises(ProjectError, match=r"g3\.npy: expected 4 columns \(sensors, in order\), got 3"):
        Project.from_toml(write_project(tmp_path, toml.replace("g.csv", "g3.npy")))
    with pytest.raises(ProjectError, match="sampling: not used when model.predictions"):
        Project.from_toml(write_project(tmp_path, toml + '\n[sampling]\nmethod = "lhs"\nn = 4\n'))
    predictions = theta @ A
    predictions[7, 2] = np.nan
    np.save(tmp_path / "gnan.npy", predictions)
    project = Project.from_toml(write_project(tmp_path, toml.replace("g.csv", "gnan.npy")))
    with pytest.raises(ProjectError, match=r"gnan\.npy: row 7: expected finite predictions, got NaN"):
        project.run(progress=False)
    predictions[7, 2] = -np.inf  # named as the file's, like NaN (was: "model: returned -inf", a Python keyword)
    np.save(tmp_path / "ginf.npy", predictions)
    project = Project.from_toml(write_project(tmp_path, toml.replace("g.csv", "ginf.npy")))
    with pytest.raises(ProjectError, match=r"ginf\.npy: row 7: expected finite predictions, got -inf \(or set nan"):
        project.run(progress=False)


# --- the command line on the shipped examples ----------------------------------------------------------

SUMMARY_KEYS = {"schema", "project", "instances", "candidates", "invalid", "model_class_falsified", "identification",
                "sampling", "parameters", "thresholds", "excluded_sensors", "diagnostics", "prognosis", "elapsed_seconds",
                "model_evaluations", "reused_evaluations", "failed_instances"}
OUTPUTS = {"summary.json", "candidates.parquet", "thresholds.csv", "report.html", "leave_one_out.png",
           "residuals.png", "scatter_matrix.png", "parallel_coordinates.png", "sensitivity.png"}


def run_example(name: str, out: Path, capsys) -> tuple[dict, str]:
    assert cli.main(["run", str(EXAMPLES / name), "--out", str(out), "--no-progress"]) == 0
    assert OUTPUTS <= {p.name for p in out.iterdir()}
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary) == SUMMARY_KEYS
    return summary, capsys.readouterr().out


def test_cli_cantilever_matches_the_paper_by_hand(tmp_path, capsys):
    summary, stdout = run_example("cantilever.toml", tmp_path / "out", capsys)
    y = pd.read_csv(EXAMPLES / "cantilever.csv")["value"].to_numpy()
    x = 500 + np.arange(1, 11) * 250.0
    E = np.linspace(20e3, 100e3, 101)
    g = 5e3 * x**2 * (3 * 3000 - x) / (6 * E[:, None] * 6.75e8)  # Eq. 12
    z = stats.norm.ppf(1 - (1 - 0.95 ** 0.1) / 2)  # Eq. 6 with phi^(1/n_m)
    sd = np.sqrt((0.15 * y) ** 2 + 0.02**2)
    ok = np.all(np.abs(g - y + 0.1 * y) <= z * sd, axis=1)
    assert summary["instances"] == 101 and summary["candidates"] == ok.sum() > 0
    assert summary["model_class_falsified"] is False
    assert summary["parameters"]["E"]["candidates"] == {"min": E[ok].min(), "max": E[ok].max()}
    assert E[ok].min() <= 70e3 <= E[ok].max()  # E* is a candidate (Sec. 4.1.2)
    low = [t["threshold_low"] for t in summary["thresholds"]]
    np.testing.assert_allclose(low, -0.1 * y - z * sd)
    frame = pd.read_parquet(tmp_path / "out" / "candidates.parquet")
    assert list(frame.columns) == ["instance", "E"] + [f"D{i}" for i in range(1, 11)]
    np.testing.assert_allclose(frame["E"], E[ok])
    assert f"candidate model set: {ok.sum()} instances" in stdout
    assert summary["prognosis"][0]["name"] == "tip deflection under 2F"


def test_cli_girder_points_at_the_faulty_gauge(tmp_path, capsys):
    summary, stdout = run_example("girder.toml", tmp_path / "out", capsys)
    assert summary["instances"] == 32768 and summary["candidates"] == 0 and summary["model_class_falsified"]
    assert summary["diagnostics"]["suspect_sensors"] == ["SG5"]
    rows = {t["sensor"]: t for t in summary["thresholds"]}
    assert rows["SG5"]["candidates_without_sensor"] > 0
    assert all(t["candidates_without_sensor"] == 0 for name, t in rows.items() if name != "SG5")
    assert "Sensor SG5 alone falsifies the model class" in stdout
    assert summary["identification"]["combined_uncertainty"] == {"exact": [f"SG{i}" for i in range(1, 8)],
                                                                 "convolution": ["D1", "D2", "D3"]}


def test_girder_without_the_faulty_gauge_keeps_the_true_girder(tmp_path):
    from edmf_rs.examples import girder

    ident = Project.from_toml(EXAMPLES / "girder-sg5-excluded.toml").run(progress=False)
    assert ident.falsification.n_candidates > 0
    truth = {"E": girder.E_TRUE, "K_rot": girder.K_ROT_TRUE, "k_h": girder.K_H_TRUE}
    for name, (lo, hi) in ident.parameter_ranges().items():
        assert lo <= truth[name] <= hi, name
    loo = ident.leave_one_out
    assert loo.candidates_without_sensor.min() == ident.falsification.n_candidates


def test_cli_broken_project_exits_2_with_one_line(tmp_path, capsys):
    text = (EXAMPLES / "cantilever.toml").read_text().replace("low = 20e3", "low = 200e3")
    path = tmp_path / "broken.toml"
    path.write_text(text)
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"edmf-rs: error: {path}: parameters.E.low: expected low < high")
    assert "Traceback" not in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_failed_write_leaves_no_summary(tmp_path, monkeypatch):
    from edmf_rs.project.report import html as report

    ident = Project.from_toml(write_project(tmp_path)).run(progress=False)
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("{}")  # from an earlier run

    def broken(*args):
        raise OSError("disk full")

    monkeypatch.setattr(report, "render", broken)
    with pytest.raises(OSError, match="disk full"):
        ident.write(out)
    assert not (out / "summary.json").exists()
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


def test_default_output_folder_is_named_after_the_project(tmp_path, capsys):
    path = write_project(tmp_path)
    assert cli.main(["run", str(path), "--no-progress"]) == 0
    assert (tmp_path / "lin" / "summary.json").is_file()


def test_two_projects_with_same_model_module_name_use_their_own(tmp_path):
    # Regression: Python's module cache must not hand project B the model of project A.
    import edmf_rs

    results = []
    for k, factor in enumerate((1.0, 2.0)):
        folder = tmp_path / f"p{k}"
        folder.mkdir()
        (folder / "model.py").write_text(f"def f(theta):\n    return theta[:, :1] * {factor}\n")
        (folder / "p.toml").write_text(
            "[parameters.a]\nlow = 0.0\nhigh = 1.0\n[sampling]\nmethod = 'grid'\npoints = { a = 11 }\n"
            "[model]\nfunction = 'model:f'\n[[sensors]]\nname = 's'\nvalue = 0.5\n"
            "[[uncertainty]]\nname = 'n'\nkind = 'measurement'\ndistribution = 'normal'\nsd = 0.01\n"
        )
        run = edmf_rs.Project.from_toml(folder / "p.toml").run(progress=False)
        results.append(run.candidates["a"].to_numpy())
    assert np.allclose(results[0], [0.5]) and np.allclose(results[1], [0.25])


def test_instance_is_a_reserved_name(tmp_path):
    import edmf_rs

    (tmp_path / "p.toml").write_text(
        "[parameters.instance]\nlow = 0.0\nhigh = 1.0\n[sampling]\nmethod = 'grid'\npoints = { instance = 3 }\n"
        "[model]\nfunction = 'math:fabs'\n[[sensors]]\nname = 's'\nvalue = 0.5\n"
        "[[uncertainty]]\nname = 'n'\nkind = 'measurement'\ndistribution = 'normal'\nsd = 0.01\n"
    )
    with pytest.raises(edmf_rs.ProjectError, match="'instance' names the index"):
        edmf_rs.Project.from_toml(tmp_path / "p.toml")


def test_excluding_a_sensor_leaves_the_other_monte_carlo_thresholds_unchanged():
    import edmf_rs

    full = edmf_rs.Project.from_toml(cli.EXAMPLES / "girder.toml")
    part = edmf_rs.Project.from_toml(cli.EXAMPLES / "girder-sg5-excluded.toml")
    a, b = full.combined_uncertainty(), part.combined_uncertainty()
    assert not a.exact  # the girder has a uniform source: Monte Carlo
    keep = [full.sensor_names.index(n) for n in part.sensor_names]
    np.testing.assert_array_equal(a.samples[:, keep], b.samples)
