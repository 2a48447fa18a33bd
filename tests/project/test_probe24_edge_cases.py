"""Edge cases a probe found (probe 24): relative sources at a reading of 0,
histograms that lost the grid's end values, NaN instances reported as
falsified, numbers too short for narrow domains, degenerate diagnostic
panels, advice to exclude the only sensor, long names in figures, temporary
files left open."""

import gc
import json
import re
import textwrap
import warnings

import numpy as np
import pandas as pd
import pytest
from edmf_rs import cli
from edmf_rs.engine.sampling import Parameter
from edmf_rs.project import Project, ProjectError
from edmf_rs.project.report import plots
from edmf_rs.project.sources import UncertaintySource, combine_sources
from matplotlib.backends.backend_agg import FigureCanvasAgg
from scipy import stats

from _projects import project_text, write_project

MODELS = textwrap.dedent("""
    from pathlib import Path
    import numpy as np

    def logged(theta):
        with open(Path(__file__).with_name("calls.log"), "a") as fh:
            fh.write(f"{len(theta)}\\n")
        return np.column_stack([theta[:, 0] + 1, theta[:, 0] * 0.5, theta[:, 0]])

    def all_nan(theta):
        return np.full((len(theta), 2), np.nan)

    def nan_at_s2(theta):
        g = np.column_stack([theta[:, 0], theta[:, 0]])
        g[:, 1] = np.nan
        return g

    def nan_above(theta):  # S1 = a, S2 = 1 - a; NaN at both sensors for a > 0.65, at S2 alone for a < 0.15
        g = np.column_stack([theta[:, 0], 1.0 - theta[:, 0]])
        g[theta[:, 0] > 0.65] = np.nan
        g[theta[:, 0] < 0.15, 1] = np.nan
        return g

    def shift(theta):
        return np.column_stack([theta[:, 0] - 293.0, (theta[:, 1] - 1000.0) * 10])

    def first(theta):
        return theta[:, :1] * 1.0

    def two(theta):
        return np.column_stack([theta[:, 0], -theta[:, 0]])

    def constant(theta):
        return np.zeros((len(theta), 1))

    def q(theta):
        return np.full(theta.shape[0], 3.0)

    def many(theta):
        return np.column_stack([theta.sum(1), theta[:, 0]] + [theta[:, 1]] * 10)
""")
NORMAL = {"kind": "model", "distribution": "normal", "sd": 0.1}


def project(tmp_path, *, parameters, points, function, csv, uncertainty=(NORMAL,), model=None, extra=""):
    text = project_text(parameters=parameters, sampling={"method": "grid", "points": points},
                        model={"function": f"m:{function}", **(model or {})}, measurements={"file": "meas.csv"},
                        uncertainty=uncertainty) + extra
    return write_project(tmp_path, text, modules={"m": MODELS}, csv=csv)


def run(tmp_path, **kwargs):
    return Project.from_toml(project(tmp_path, **kwargs)).run(progress=False)


# --- 1. sources relative to a reading of 0, or asymmetric at a negative reading -----------------------------

RELATIVE = {"name": "relative model error", "kind": "model", "distribution": "normal", "sd": 0.1,
            "relative_to": "measured"}
THREE = "sensor,value\nS1,1.0\nS2,0.5\nGAUGE_C,0\n"


def test_relative_source_at_a_reading_of_0_is_refused_before_any_model_run(tmp_path):
    path = project(tmp_path, parameters={"a": (-1.0, 1.0)}, points={"a": 21}, function="logged", csv=THREE,
                   uncertainty=(RELATIVE,))
    with pytest.raises(ProjectError) as err:
        Project.from_toml(path)
    text = str(err.value)
    for fragment in ("p.toml", "'relative model error'", "sensor 'GAUGE_C'", "measured as 0", "no spread"):
        assert fragment in text, (fragment, text)
    assert "sensor 0" not in text
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    assert not (tmp_path / "calls.log").exists()  # the model was never called


def test_lognorm_relative_source_at_a_negative_reading_names_source_and_sensor(tmp_path):
    lognorm = {"name": "relative model error", "kind": "model", "distribution": "lognorm", "params": {"s": 0.25},
               "relative_to": "measured"}
    path = project(tmp_path, parameters={"a": (-1.0, 1.0)}, points={"a": 21}, function="logged",
                   csv="sensor,value\nS1,1.0\nS2,0.5\nGAUGE_C,-2\n", uncertainty=(lognorm,))
    with pytest.raises(ProjectError) as err:
        Project.from_toml(path)
    text = str(err.value)
    for fragment in ("p.toml", "uncertainty[0]", "'relative model error'", "sensor 'GAUGE_C'", "-2", "lognorm"):
        assert fragment in text, (fragment, text)
    assert not (tmp_path / "calls.log").exists()


def test_a_reading_of_0_with_an_absolute_source_too_is_fine(tmp_path):
    noise = {"name": "noise", "kind": "measurement", "distribution": "normal", "sd": 0.05}
    ident = run(tmp_path, parameters={"a": (-1.0, 1.0)}, points={"a": 21}, function="logged", csv=THREE,
                uncertainty=(RELATIVE, noise))
    assert ident.combined.std[2] == pytest.approx(0.05)  # only the noise at GAUGE_C
    assert ident.combined.std[0] == pytest.approx(np.hypot(0.1, 0.05))


def test_combining_one_sensor_at_a_time_names_that_sensor():
    src = UncertaintySource("rel", "model", "normal", (0.0, 0.1), "measured", (0, 1, 2))
    with pytest.raises(ValueError) as err:
        combine_sources((src,), np.array([1.0, 0.5, 0.0]), sensor_names=("S1", "S2", "GAUGE_C"))
    assert "sensor 'GAUGE_C'" in str(err.value) and "sensor 0" not in str(err.value)


# --- 2. histograms keep the grid's end values -----------------------------------------------------------------

def test_bins_hold_every_grid_value_linear_and_log():
    for param, n in ((Parameter("a", -0.3, 0.9), 11), (Parameter("k", 1e-3, 1e3, scale="log"), 7),
                     (Parameter("x", 1000.0, 1000.4), 9)):
        values = param.grid(n)
        counts, _ = np.histogram(values, plots._bins(values, param))
        assert counts.tolist() == [1] * n, param


def test_scatter_matrix_histograms_count_every_candidate(tmp_path):
    ident = run(tmp_path, parameters={"k": {"low": 1e-3, "high": 1e3, "scale": "log"}, "a": (-0.3, 0.9)},
                points={"k": 7, "a": 11}, function="constant", csv="sensor,value\nS1,0\n")
    assert ident.falsification.n_candidates == 77  # every instance: the grid's end values are candidates
    fig = plots.scatter_matrix(ident)
    for i in range(2):
        ax = fig.axes[i * 2 + i]
        instances, candidates = ax.containers
        assert sum(bar.get_height() for bar in instances) == 77
        assert sum(bar.get_height() for bar in candidates) == 77


# --- 3. invalid instances (NaN) are neither candidates nor falsified ----------------------------------------------

NAN = {"nan": "falsify"}
TWO = "sensor,value\nS1,0.5\nS2,0.5\n"


def test_all_nan_instances_are_reported_invalid_not_falsified(tmp_path):
    ident = run(tmp_path, parameters={"a": (0.0, 1.0)}, points={"a": 11}, function="all_nan", csv=TWO, model=NAN)
    out = ident.write(tmp_path / "out")
    report = (out / "report.html").read_text()
    verdict = re.search(r"<div class='verdict[^>]*>(.*?)</div>", report).group(1)
    assert "falsified by the measurements" not in verdict and "invalid" in verdict and "11" in verdict
    assert "Invalid instances" in report  # what invalid means, among the definitions
    table = pd.read_csv(out / "thresholds.csv")
    assert table["falsified"].tolist() == [0, 0] and table["falsified_only_by"].tolist() == [0, 0]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["invalid"] == 11 and summary["diagnostics"]["suspect_sensors"] == []
    findings = " ".join(summary["diagnostics"]["findings"])
    assert "invalid" in findings and "No single sensor explains" not in findings
    assert "every instance is falsified" not in ident.summary()


def test_a_nan_column_does_not_blame_its_sensor(tmp_path):
    ident = run(tmp_path, parameters={"a": (0.0, 1.0)}, points={"a": 11}, function="nan_at_s2", csv=TWO, model=NAN)
    findings = " ".join(ident.findings())
    assert "alone falsifies" not in findings and "faulty" not in findings and "exclude" not in findings
    assert "S2 (11)" in findings  # where the NaN are
    assert ident.leave_one_out.suspects == ()
    top = plots.leave_one_out(ident).axes[0]
    assert [bar.get_height() for bar in top.patches] == [0, 0]


def test_per_sensor_counts_leave_out_invalid_instances(tmp_path):
    ident = run(tmp_path, parameters={"a": (0.0, 1.0)}, points={"a": 21}, function="nan_above", csv=TWO, model=NAN)
    a = np.linspace(0.0, 1.0, 21)
    half = 0.1 * stats.norm.ppf((1 + 0.95 ** 0.5) / 2)  # normal sd 0.1, Sidak over 2 sensors
    valid = (a >= 0.15) & (a <= 0.65)
    out1, out2 = np.abs(a - 0.5) > half, np.abs(0.5 - a) > half  # S1 = a, S2 = 1 - a, y = 0.5
    assert ident.falsification.n_invalid == int((~valid).sum())
    assert ident.falsification.n_candidates == int((valid & ~out1 & ~out2).sum())
    out = ident.write(tmp_path / "out")
    table = pd.read_csv(out / "thresholds.csv")
    assert table["falsified"].tolist() == [int((valid & out1).sum()), int((valid & out2).sum())]
    assert table["falsified_only_by"].tolist() == [int((valid & out1 & ~out2).sum()),
                                                   int((valid & out2 & ~out1).sum())]
    verdict = re.search(r"<div class='verdict[^>]*>(.*?)</div>", (out / "report.html").read_text()).group(1)
    assert f"{int((~valid).sum())} of the 21 instances are invalid" in verdict
    bottom = plots.leave_one_out(ident).axes[1]
    assert bottom.get_ylabel() == "% of valid instances"


# --- 4. enough digits for narrow domains ------------------------------------------------------------------------

NARROW = {"T": {"low": 293.0, "high": 293.5, "unit": "K"}, "x": {"low": 1000.0, "high": 1000.04, "unit": "mm"}}


@pytest.fixture(scope="module")
def narrow(tmp_path_factory):
    """x in 1000.0 .. 1000.04 (9 points), S2 = 10 (x - 1000) measured 0.3 with sd 0.05: candidates at x
    in 1000.02 .. 1000.04 (|S2 - 0.3| <= 0.05 * 2.236, Sidak over 2 sensors); T alike around 293.2."""
    tmp_path = tmp_path_factory.mktemp("narrow")
    return run(tmp_path, parameters=NARROW, points={"T": 11, "x": 9}, function="shift",
               csv="sensor,value\nS1,0.2\nS2,0.3\n", uncertainty=({**NORMAL, "sd": 0.05},)), tmp_path


def test_narrow_domains_show_distinct_numbers_in_the_summary(narrow):
    ident, _ = narrow
    line = next(t for t in ident.summary().splitlines() if t.strip().startswith("x [mm]"))
    shown = re.findall(r"[\d,]+\.\d+|[\d,]+", line.split(":", 1)[1])
    assert [float(v.replace(",", "")) for v in shown] == pytest.approx([1000.02, 1000.04, 1000.0, 1000.04], abs=1e-4)
    assert len(set(shown)) == 3, line  # 1000.04 twice: the candidates' max and the domain's high


def test_narrow_domains_get_tick_labels_that_differ(narrow):
    ident, _ = narrow
    fig = plots.scatter_matrix(ident)
    FigureCanvasAgg(fig).draw()
    checked = 0
    for ax in (a for a in fig.axes if a.get_visible()):
        for labels in (ax.get_xticklabels(), ax.get_yticklabels()):
            texts = [t.get_text() for t in labels if t.get_text()]
            assert len(set(texts)) == len(texts), texts
            checked += len(texts)
    assert checked >= 12


def test_narrow_domains_show_distinct_numbers_in_the_report(narrow):
    ident, tmp_path = narrow
    report = (ident.write(tmp_path / "out") / "report.html").read_text()
    row = re.search(r"<td class='l'>x</td>.*?</tr>", report).group(0)
    cells = re.findall(r"<td class=''>([^<]*)</td>", row)  # domain low, high, candidates min, max
    assert [float(c.replace(",", "")) for c in cells] == pytest.approx([1000.0, 1000.04, 1000.02, 1000.04], abs=1e-4)
    assert len(set(cells)) == 3, cells


def test_in_domain_digits_follow_the_width():
    from edmf_rs.project.format import in_domain

    assert in_domain(1000.2, 1000.0, 1000.4) != in_domain(1000.4, 1000.0, 1000.4)
    assert in_domain(293.05, 293.0, 293.1) != in_domain(293.0, 293.0, 293.1)
    assert in_domain(35000.0, 20e3, 50e3) == "35,000"  # wide domains keep 4 significant digits


# --- 5. degenerate diagnostic panels ------------------------------------------------------------------------

def integers(ax) -> bool:
    low, high = ax.get_ylim()
    ticks = [t for t in ax.get_yticks() if low <= t <= high]
    return all(float(t).is_integer() for t in ticks)


def test_one_instance_one_sensor_one_candidate_gets_counting_axes(tmp_path):
    ident = run(tmp_path, parameters={"a": (0.0, 2.0)}, points={"a": 1}, function="first",
                csv="sensor,value\nS1,1.0\n")
    assert ident.falsification.n_candidates == 1
    top, bottom = plots.leave_one_out(ident).axes
    assert top.get_ylim()[0] == 0 and top.get_ylim()[1] >= 1 and integers(top)
    assert bottom.get_ylim()[0] == 0
    assert any("No instance is falsified" in t.get_text() for t in bottom.texts)


def test_every_instance_falsified_gets_notes_not_fractional_axes(tmp_path):
    ident = run(tmp_path, parameters={"a": (0.0, 2.0)}, points={"a": 3}, function="two",
                csv="sensor,value\nS1,50.0\nS2,50.0\n")
    assert ident.falsification.n_candidates == 0 and not ident.sensitivity.candidates_at_scale.any()
    left = plots.sensitivity(ident).axes[0]
    assert any("No instance is a candidate" in t.get_text() for t in left.texts)
    assert list(left.get_yticks()) == []
    top = plots.leave_one_out(ident).axes[0]
    assert not ident.leave_one_out.candidates_without_sensor.any()
    assert any("No candidate" in t.get_text() for t in top.texts) and list(top.get_yticks()) == []


# --- 6. the only sensor, and plurals -------------------------------------------------------------------------

def test_the_only_sensor_is_not_advised_to_be_excluded(tmp_path):
    ident = run(tmp_path, parameters={"a": (0.0, 2.0)}, points={"a": 1}, function="first",
                csv="sensor,value\nS1,5.0\n")
    text = " ".join(ident.findings())
    assert "exclude" not in text and "only sensor" in text and "1 candidates" not in text
    assert ident.summary().splitlines()[0].startswith("p: 1 model instance, 1 sensor, ")


def test_one_candidate_left_reads_in_the_singular(tmp_path):
    ident = run(tmp_path, parameters={"a": (-5.0, -1.0)}, points={"a": 11}, function="two",
                csv="sensor,value\nS1,10.0\nS2,1\n")
    text = " ".join(ident.findings())
    assert "ignoring it leaves 1 candidate." in text and "1 candidates" not in text


# --- 7. long names in figures --------------------------------------------------------------------------------

LONG_P, LONG_Q = "P" * 300, "Q" * 200 + " [x]"


def long_names(tmp_path):
    unit = "U" * 80
    sensors = ["S" * 250, "B"] + [f"{'Z' * 100}{k}" for k in range(10)]
    quoted = f'"{LONG_Q}"'  # a TOML key with a space and brackets
    return run(tmp_path, parameters={LONG_P: {"low": 0.0, "high": 1.0, "unit": unit},
                                     quoted: {"low": 0.0, "high": 1.0, "unit": unit},
                                     "r": {"low": 0.0, "high": 1.0, "unit": unit}},
               points={LONG_P: 3, quoted: 3, "r": 3}, function="many",
               csv="sensor,value\n" + "".join(f"{s},{v}\n" for s, v in zip(sensors, [1.5] + [0.5] * 11)),
               uncertainty=({**NORMAL, "sd": 0.3},)), sensors


def inside(fig, texts, renderer) -> bool:
    box = fig.bbox
    return all(box.x0 - 1 <= t.get_window_extent(renderer).x0 and t.get_window_extent(renderer).x1 <= box.x1 + 1
               and box.y0 - 1 <= t.get_window_extent(renderer).y0 for t in texts)


def apart(fig, labels, renderer) -> bool:
    """Tick labels that do not run into each other: their boxes do not overlap, or
    they are turned by the same angle and the parallel lines are a text height apart."""
    boxes = [t.get_window_extent(renderer) for t in labels]
    if not any(p.overlaps(q) for i, p in enumerate(boxes) for q in boxes[i + 1:]):
        return True
    angles = {t.get_rotation() for t in labels}
    if len(angles) != 1 or not 30 <= angles.pop() <= 90:
        return False
    angle = np.radians(labels[0].get_rotation())
    x = np.array([fig.axes[-1].transData.transform((t.get_position()[0], 0))[0] for t in labels])
    height = labels[0].get_fontsize() * fig.dpi / 72
    return bool(np.min(np.diff(x)) * np.sin(angle) >= height)


def test_long_names_are_shortened_in_figures_and_kept_in_the_report(tmp_path):
    ident, sensors = long_names(tmp_path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        figures = {name: getattr(plots, name)(ident) for name in ("scatter_matrix", "residuals", "leave_one_out")}
        for fig in figures.values():
            FigureCanvasAgg(fig).draw()
    assert not [w for w in caught if "constrained_layout" in str(w.message)]
    for name in ("residuals", "leave_one_out"):
        fig = figures[name]
        renderer = fig.canvas.get_renderer()
        labels = [t for t in fig.axes[-1].get_xticklabels() if t.get_text()]
        texts = [t.get_text() for t in labels]
        assert len(texts) == len(sensors) == len(set(texts)), texts
        assert max(map(len, texts)) <= 30 and inside(fig, labels, renderer), texts
        assert apart(fig, labels, renderer), name
    fig = figures["scatter_matrix"]
    axis_labels = [ax.xaxis.label for ax in fig.axes if ax.get_visible()] + \
        [ax.yaxis.label for ax in fig.axes if ax.get_visible() and ax.get_ylabel()]
    assert axis_labels and all(len(t.get_text()) <= 40 for t in axis_labels)
    assert inside(fig, axis_labels, fig.canvas.get_renderer())
    report = (ident.write(tmp_path / "out") / "report.html").read_text()
    assert LONG_P in report and sensors[0] in report


# --- minor: temporary files closed -----------------------------------------------------------------------------

@pytest.mark.parametrize("reading", [1.0, 5.0])  # a candidate, and none
def test_a_run_leaves_no_file_open(tmp_path, reading):
    path = project(tmp_path, parameters={"a": (0.0, 2.0)}, points={"a": 1}, function="first",
                   csv=f"sensor,value\nS1,{reading}\n", extra='\n[[prognosis]]\nname = "q"\nfunction = "m:q"\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ResourceWarning)
        ident = Project.from_toml(path).run(progress=False)
        assert (ident.falsification.n_candidates == 1) == (reading == 1.0)
        del ident
        gc.collect()
    assert not [str(w.message) for w in caught if issubclass(w.category, ResourceWarning)]


def test_the_plan_of_one_instance_one_parameter_one_sensor_reads_in_the_singular():
    from edmf_rs.engine.sampling import Parameter, grid, latin_hypercube

    assert grid([Parameter("E", 1.0, 2.0)], [1]).describe() == "grid 1 = 1 instance"
    assert latin_hypercube([Parameter("E", 1.0, 2.0)], 1, seed=0).describe().startswith("Latin hypercube, 1 instance,")
