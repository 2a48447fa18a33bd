"""The HTML report is one self-contained page that says what the diagnostics found."""

import base64
from html.parser import HTMLParser
from pathlib import Path

import edmf_rs
import pandas as pd
import pytest
from edmf_rs.project import Project

EXAMPLES = Path(edmf_rs.__file__).parent / "examples" / "projects"
PNG = b"\x89PNG\r\n\x1a\n"


class Page(HTMLParser):
    def __init__(self, html: str):
        super().__init__()
        self.tags, self.images, self.links = [], [], []
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        attrs = dict(attrs)
        if tag == "img":
            self.images.append(attrs.get("src", ""))
        self.links += [v for k, v in attrs.items() if k in ("href", "src") and tag != "img"]


def cantilever(tmp_path: Path, shift: float = 0.0, name: str = "Beam <2> & co") -> Path:
    """The shipped cantilever project, renamed, with sensor D4 shifted by ``shift`` mm."""
    frame = pd.read_csv(EXAMPLES / "cantilever.csv")
    frame.loc[frame.sensor == "D4", "value"] += shift
    frame.to_csv(tmp_path / "meas.csv", index=False)
    text = (EXAMPLES / "cantilever.toml").read_text()
    text = text.replace('name = "Cantilever beam, scenario 2"', f'name = "{name}"')
    text = text.replace('path = "."', f'path = "{EXAMPLES.as_posix()}"')
    text = text.replace('file = "cantilever.csv"', 'file = "meas.csv"')
    path = tmp_path / "beam.toml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def falsified(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("falsified")
    out = Project.from_toml(cantilever(tmp, shift=1.0)).run(progress=False).write(tmp / "out")
    return (out / "report.html").read_text(encoding="utf-8")


def test_report_is_self_contained(falsified):
    page = Page(falsified)
    assert {"script", "link", "iframe", "object", "embed"}.isdisjoint(page.tags)
    assert page.links == []
    assert len(page.images) == 5
    for src in page.images:
        prefix = "data:image/png;base64,"
        assert src.startswith(prefix)
        assert base64.b64decode(src[len(prefix):]).startswith(PNG)
    assert "url(" not in falsified and "http://" not in falsified and "https://" not in falsified


def test_report_escapes_user_text(falsified):
    assert "Beam &lt;2&gt; &amp; co" in falsified and "<2>" not in falsified


def test_report_names_the_sensor_that_alone_falsifies_the_model_class(falsified):
    assert "Model class falsified" in falsified
    assert "Sensor D4 alone falsifies the model class" in falsified
    assert "<tr class='suspect'><td class='l'>D4</td>" in falsified
    assert "No prognosis: the model class is falsified" in falsified


def test_report_of_a_candidate_set(tmp_path):
    out = Project.from_toml(cantilever(tmp_path, name="Beam")).run(progress=False).write(tmp_path / "out")
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "candidate models</b> of 101 instances" in html
    assert "<td class='l'>tip deflection under 2F</td>" in html
    assert "Model class falsified" not in html
    assert len(Page(html).images) == 5


def test_plot_sample_takes_every_kth_instance_across_batches():
    import numpy as np
    from edmf_rs.project.result import PlotSample

    sample = PlotSample(10, limit=3)  # stride 4: instances 0, 4, 8
    for offset in (0, 3, 6, 9):
        rows = np.arange(offset, min(offset + 3, 10), dtype=float)[:, None]
        sample(offset, rows, rows * 10)
    mask = np.zeros(10, bool)
    mask[4] = True
    done = sample.finish(mask)
    assert done.index.tolist() == [0, 4, 8]
    assert done.parameters[:, 0].tolist() == [0.0, 4.0, 8.0] and done.predictions[:, 0].tolist() == [0, 40, 80]
    assert done.is_candidate.tolist() == [False, True, False]
