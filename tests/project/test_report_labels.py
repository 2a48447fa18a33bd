"""Report figures that read well (issue 12, part 8): tick labels that never
overlap, names shown as written, no all-zero curve against phi, the same bound
names in thresholds.csv and the report, a plain prognosis line."""

import textwrap

import numpy as np
import pandas as pd
import pytest
from edmf_rs.project import Project, predict
from edmf_rs.project.report import plots
from matplotlib.backends.backend_agg import FigureCanvasAgg
from scipy import stats

from _projects import project_text, write_project

MODEL = textwrap.dedent("""
    import numpy as np
    def g(theta):
        e, k, c = theta[:, 0] / 3.5e4, np.log10(theta[:, 1]) / 12, theta[:, 2] / 2e-6
        return np.column_stack([e + k, e - c, k * c])
""")


def project(tmp_path, y=(2.0, 0.0, 1.0), names=("D$1", "R_2$", "$x")):
    text = project_text(
        parameters={"E": {"low": 20e3, "high": 50e3, "unit": "MPa"}, "K": {"low": 1e10, "high": 1e14, "scale": "log"},
                    "c": (1e-6, 3e-6)},
        sampling={"method": "sobol", "n": 1024}, model={"function": "big:g"}, measurements={"file": "meas.csv"},
        uncertainty=[{"name": "noise", "kind": "measurement", "distribution": "normal", "sd": 0.2}])
    rows = "".join(f"{n},{v}\n" for n, v in zip(names, y))
    return Project.from_toml(write_project(tmp_path, text, modules={"big": MODEL}, csv="sensor,value\n" + rows))


def overlapping(labels, renderer) -> list:
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in labels if t.get_visible() and t.get_text()]
    return [(a, b) for i, (a, p) in enumerate(boxes) for b, q in boxes[i + 1:] if p.overlaps(q)]


def test_scatter_matrix_tick_labels_never_overlap(tmp_path):
    ident = project(tmp_path).run(progress=False)
    assert ident.falsification.n_candidates > 0
    fig = plots.scatter_matrix(ident)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 6
    for ax in axes:
        assert overlapping(ax.get_xticklabels(), renderer) == []
        assert overlapping(ax.get_yticklabels(), renderer) == []
        assert all(len(t.get_text()) <= 8 for t in ax.get_xticklabels() if "mathdefault" not in t.get_text())
    E_axis = axes[0]  # the E histogram, 20e3 .. 50e3
    texts = [t.get_text() for t in E_axis.get_xticklabels() if t.get_text()]
    assert texts and all("e4" in t for t in texts), texts


def test_names_with_dollar_signs_render_and_write(tmp_path):
    ident = project(tmp_path).run(progress=False)
    out = ident.write(tmp_path / "out")
    assert (out / "residuals.png").stat().st_size > 0 and (out / "leave_one_out.png").is_file()
    assert "D$1" in (out / "report.html").read_text()


def test_phi_plot_draws_no_all_zero_curve(tmp_path):
    ident = project(tmp_path, y=(50.0, 50.0, 50.0)).run(progress=False)  # nothing near: model class falsified
    assert ident.falsification.n_candidates == 0 and not ident.sensitivity.candidates_at_phi.any()
    fig = plots.sensitivity(ident)
    right = fig.axes[1]
    curves = [line for line in right.get_lines() if np.size(line.get_xdata()) > 2]
    assert curves == []
    assert any("No instance is a candidate" in t.get_text() for t in right.texts)
    FigureCanvasAgg(fig).draw()


def test_thresholds_csv_and_report_name_the_bounds_alike(tmp_path):
    ident = project(tmp_path).run(progress=False)
    out = ident.write(tmp_path / "out")
    columns = list(pd.read_csv(out / "thresholds.csv").columns)
    assert "threshold_low" in columns and "threshold_high" in columns
    html = (out / "report.html").read_text()
    for name in columns:
        assert f">{name}</th>" in html, name


def test_prognosis_line_says_what_each_range_is():
    p = predict(lambda t: t[:, 0], np.array([[4.0], [5.0]]), uncertainty=stats.norm(0.0, 0.5), name="q", unit="mm")
    line = p.summary()
    assert line.startswith("q: the candidate models predict 4 .. 5 mm; with its model uncertainty (95% interval of "
                           "prediction - true value: ")
    assert line.endswith(f"the true value is in {p.low:.4g} .. {p.high:.4g} mm")
    bare = predict(lambda t: t[:, 0], np.array([[4.0], [5.0]]), name="q")
    assert bare.summary() == "q: the candidate models predict 4 .. 5 (no model uncertainty given for it)"


@pytest.mark.parametrize("value, text", [(35000.0, "3.5e4"), (0.25, "0.25"), (1e-6, "1e-6"), (123.0, "123")])
def test_short_tick_labels(value, text):
    assert plots.short(value) == text
