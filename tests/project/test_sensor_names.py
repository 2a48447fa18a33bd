"""Sensors by name: model outputs and measurements matched by name in any order
(issue 12, part 1), in project files and in the Python API."""

import re
import shutil
import textwrap
from pathlib import Path

import edmf_rs
import numpy as np
import pandas as pd
import pytest
from edmf_rs.engine.sensors import SensorMatch, SensorMismatch
from edmf_rs.project import Project, ProjectError
from scipy import stats

EXAMPLES = Path(edmf_rs.__file__).parent / "examples" / "projects"
GIRDER_NAMES = ["D1", "D2", "D3", "SG1", "SG2", "SG3", "SG4", "SG5", "SG6", "SG7"]


def girder_copy(folder: Path, *, rows=None, model=None, extra_model: str = "", n: int = 2048) -> Path:
    """girder-sg5-excluded.toml in ``folder``, its CSV rows in the order ``rows``
    (names), its model ``model`` ('module:function' in ``folder``), Sobol' n."""
    folder.mkdir(parents=True, exist_ok=True)
    csv = (EXAMPLES / "girder.csv").read_text().splitlines()
    header, body = csv[0], {line.split(",")[0]: line for line in csv[1:]}
    order = rows or GIRDER_NAMES
    (folder / "girder.csv").write_text("\n".join([header] + [body[name] for name in order]) + "\n")
    toml = (EXAMPLES / "girder-sg5-excluded.toml").read_text().replace("n = 32768", f"n = {n}")
    assert f"n = {n}" in toml
    if model is not None:
        toml = re.sub(r'function = "edmf_rs.examples.girder:predict"\nsensors = .*\n',
                      f'function = "{model}"\npath = "."{extra_model}\n', toml)
        assert model in toml
    path = folder / "girder.toml"
    path.write_text(toml)
    return path


SHUFFLED_MODEL = textwrap.dedent("""
    import numpy as np
    import pandas as pd
    from edmf_rs.examples import girder
    NAMES = ["D1", "D2", "D3", "SG1", "SG2", "SG3", "SG4", "SG5", "SG6", "SG7"]
    ORDER = [3, 9, 0, 6, 2, 8, 5, 1, 7, 4]

    def frame(theta):
        g = girder.predict(theta)
        return pd.DataFrame(g, columns=NAMES).iloc[:, ORDER]

    def mapping(theta):
        g = girder.predict(theta)
        out = {NAMES[j]: g[:, j] for j in ORDER}
        out["T_air"] = np.full(len(theta), 20.0)  # an output no sensor measures
        return out

    def structured(theta):
        g = girder.predict(theta)
        out = np.empty(len(theta), dtype=[(NAMES[j], "f8") for j in ORDER])
        for j in ORDER:
            out[NAMES[j]] = g[:, j]
        return out

    def permuted(theta):  # a bare array in ORDER: only [model] sensors can say so
        return girder.predict(theta)[:, ORDER]
""")
ORDER = [3, 9, 0, 6, 2, 8, 5, 1, 7, 4]


@pytest.fixture(scope="module")
def unshuffled(tmp_path_factory):
    ident = Project.from_toml(girder_copy(tmp_path_factory.mktemp("plain"))).run(progress=False)
    assert ident.falsification.n_candidates > 0
    return ident


@pytest.fixture(scope="module")
def positional_wrong(tmp_path_factory):
    """What the old code computed for swapped CSV rows: the model's columns read
    in the CSV's order. Reproduced by declaring the columns in a wrong order."""
    folder = tmp_path_factory.mktemp("wrong")
    (folder / "shuffled_model.py").write_text(SHUFFLED_MODEL)
    listed = ", ".join(f'"{GIRDER_NAMES[j]}"' for j in range(10))  # but the model returns ORDER
    ident = Project.from_toml(girder_copy(folder, model="shuffled_model:permuted",
                                          extra_model=f"\nsensors = [{listed}]")).run(progress=False)
    return ident.falsification.n_candidates


def test_swapped_csv_rows_give_the_unshuffled_candidates(tmp_path, unshuffled, positional_wrong):
    rows = ["SG1", "D2", "D3", "D1"] + GIRDER_NAMES[4:]  # D1 and SG1 swapped
    ident = Project.from_toml(girder_copy(tmp_path, rows=rows)).run(progress=False)
    np.testing.assert_array_equal(ident.falsification.candidate_indices, unshuffled.falsification.candidate_indices)
    assert ident.candidates.equals(unshuffled.candidates[ident.candidates.columns])


def test_positional_reading_would_give_another_count(unshuffled, positional_wrong):
    assert positional_wrong != unshuffled.falsification.n_candidates


@pytest.mark.parametrize("function", ["frame", "mapping", "structured"])
def test_shuffled_named_model_outputs_give_the_unshuffled_candidates(tmp_path, unshuffled, function):
    (tmp_path / "shuffled_model.py").write_text(SHUFFLED_MODEL)
    rows = list(reversed(GIRDER_NAMES))  # and the CSV in yet another order
    ident = Project.from_toml(girder_copy(tmp_path, rows=rows, model=f"shuffled_model:{function}")).run(progress=False)
    np.testing.assert_array_equal(ident.falsification.candidate_indices, unshuffled.falsification.candidate_indices)
    assert ident.sensor_mapping.how == "by name"
    text = ident.summary()
    if function == "mapping":
        assert "T_air" in ident.sensor_mapping.ignored and "T_air" in text
    assert "matched to the sensors by name" in text


def test_bare_array_follows_model_sensors(tmp_path, unshuffled):
    (tmp_path / "shuffled_model.py").write_text(SHUFFLED_MODEL)
    listed = ", ".join(f'"{GIRDER_NAMES[j]}"' for j in ORDER)
    ident = Project.from_toml(girder_copy(tmp_path, model="shuffled_model:permuted",
                                          extra_model=f"\nsensors = [{listed}]")).run(progress=False)
    np.testing.assert_array_equal(ident.falsification.candidate_indices, unshuffled.falsification.candidate_indices)
    assert "[model] sensors" in ident.sensor_mapping.how
    out = ident.write(tmp_path / "out")
    assert "[model] sensors" in (out / "report.html").read_text()


MODEL = textwrap.dedent("""
    import numpy as np
    import pandas as pd
    def two(theta):
        return pd.DataFrame({"S1": theta[:, 0], "S3": theta[:, 0]})
    def bare3(theta):
        return np.column_stack([theta[:, 0]] * 3)
""")
PROJECT = textwrap.dedent("""
    [parameters.a]
    low = 0.0
    high = 1.0
    [sampling]
    method = "grid"
    points = { a = 5 }
    [model]
    function = "m:FUNC"
    [measurements]
    file = "meas.csv"
    [[uncertainty]]
    name = "noise"
    kind = "measurement"
    distribution = "normal"
    sd = 0.5
""")


def small(tmp_path, func, extra=""):
    (tmp_path / "m.py").write_text(MODEL)
    (tmp_path / "meas.csv").write_text("sensor,value\nS1,0.5\nS2,0.5\n")
    (tmp_path / "p.toml").write_text(PROJECT.replace("FUNC", func).replace("[measurements]", extra + "[measurements]"))
    return tmp_path / "p.toml"


def test_missing_sensor_names_both_sides(tmp_path):
    project = Project.from_toml(small(tmp_path, "two"))
    with pytest.raises(ProjectError) as err:
        project.run(progress=False)
    message = str(err.value)
    assert "no prediction for sensor S2" in message
    assert "the measurements have S1, S2" in message and "S1, S3" in message


def test_model_sensors_must_cover_the_measurements(tmp_path):
    with pytest.raises(ProjectError, match=r"model\.sensors: expected every sensor of the measurements, missing S2"):
        Project.from_toml(small(tmp_path, "bare3", extra='sensors = ["S1", "S3", "S4"]\n'))


def test_model_sensors_with_a_bare_array_of_other_width(tmp_path):
    project = Project.from_toml(small(tmp_path, "bare3"))
    with pytest.raises(ProjectError, match=r"returned shape \(5, 3\) for 5 parameter sets, expected \(5, 2\): one "
                                           r"column per sensor, in the measurements' order \(S1, S2\)"):
        project.run(progress=False)


# --- the Python API ------------------------------------------------------------------------------------

def api_case():
    rng = np.random.default_rng(3)
    theta = rng.uniform(0, 2, (500, 2))
    A = np.array([[1.0, 2.0, 0.5], [0.3, -0.2, 1.5]])
    y = np.array([1.3, 1.8, 2.0])
    combined = edmf_rs.combine(model=[stats.norm(0, 0.3)], measurement=[stats.norm(0, 0.2)], n_sensors=3)
    return theta, A, y, edmf_rs.threshold_bounds(combined, 0.95)


def test_falsify_model_matches_named_columns_by_name():
    theta, A, y, thresholds = api_case()
    plain = edmf_rs.falsify_model(lambda t: t @ A, theta, y, thresholds, progress=False)
    assert 0 < plain.n_candidates < 500
    names = ["S1", "S2", "S3"]

    def frame(t):
        return pd.DataFrame(t @ A, columns=names)[["S3", "S1", "S2"]]

    named = edmf_rs.falsify_model(frame, theta, y, thresholds, progress=False, sensors=names, batch_size=64)
    np.testing.assert_array_equal(named.candidate_indices, plain.candidate_indices)
    np.testing.assert_array_equal(named.candidate_predictions, plain.candidate_predictions)
    with pytest.raises(TypeError, match=r"named columns \(S3, S1, S2\).*pass sensors="):
        edmf_rs.falsify_model(frame, theta, y, thresholds, progress=False)

    def extra(t):
        g = t @ A
        return {"T": g[:, 0], "S2": g[:, 1], "S3": g[:, 2], "S1": g[:, 0]}

    with pytest.warns(UserWarning, match="ignored: T"):
        named = edmf_rs.falsify_model(extra, theta, y, thresholds, progress=False, sensors=names)
    np.testing.assert_array_equal(named.candidate_indices, plain.candidate_indices)
    with pytest.raises(ValueError, match=r"no prediction for sensor S1: the measurements have S1, S2, S3"):
        edmf_rs.falsify_model(lambda t: {"S2": t[:, 0], "S3": t[:, 1]}, theta, y, thresholds, progress=False,
                              sensors=names)
    with pytest.raises(ValueError, match=r"sensors: expected 3 names"):
        edmf_rs.falsify_model(frame, theta, y, thresholds, progress=False, sensors=names[:2])


def test_sensor_match_rejects_duplicate_output_names():
    match = SensorMatch(["a", "b"])
    with pytest.raises(SensorMismatch, match=re.escape("columns named twice: a")):
        match(pd.DataFrame(np.zeros((2, 3)), columns=["a", "b", "a"]), 2)


def test_cantilever_with_swapped_rows_keeps_its_candidates(tmp_path):
    for name in ("cantilever.toml", "cantilever_model.py"):
        shutil.copy(EXAMPLES / name, tmp_path / name)
    lines = (EXAMPLES / "cantilever.csv").read_text().splitlines()
    lines[1], lines[10] = lines[10], lines[1]  # D1 and D10
    assert lines[1].startswith("D10,") and lines[10].startswith("D1,")
    (tmp_path / "cantilever.csv").write_text("\n".join(lines) + "\n")
    shuffled = Project.from_toml(tmp_path / "cantilever.toml").run(progress=False)
    plain = Project.from_toml(EXAMPLES / "cantilever.toml").run(progress=False)
    assert plain.falsification.n_candidates > 0
    np.testing.assert_array_equal(shuffled.falsification.candidate_indices, plain.falsification.candidate_indices)
