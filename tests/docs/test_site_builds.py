"""The documentation site builds from the code with warnings as errors
(``mkdocs build --strict``), and its pages' Python examples run."""

import html
import os
import re
import subprocess
import sys

from api_pages import ROOT

DOCS = ROOT / "docs"


def test_site_builds_strictly(tmp_path):
    site = tmp_path / "site"
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file", str(ROOT / "mkdocs.yml"),
         "--site-dir", str(site)],
        cwd=ROOT, capture_output=True, text=True, env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert out.returncode == 0, out.stdout + out.stderr
    log = out.stdout + out.stderr
    assert not re.search(r"^(WARNING|ERROR)\b", log, flags=re.M), log
    api = (site / "api" / "index.html").read_text(encoding="utf-8")
    # The API reference is generated from the docstrings: their sections and examples are on the page.
    for anchor in ("edmf_rs.combine", "edmf_rs.threshold_bounds", "edmf_rs.falsify", "edmf_rs.project.Project",
                   "edmf_rs.reference.falsify", "edmf_rs.dask.falsify", "edmf_rs.paper.cantilever.deflection"):
        assert f'id="{anchor}"' in api, anchor
    text = html.unescape(re.sub(r"<[^>]+>", "", api))
    assert "Combine uncertainty sources into U_c per sensor" in text
    assert ">>> uc = edmf_rs.combine(model=edmf_rs.relative_to_measured(stats.norm(-0.10, 0.15), y)," in text
    for page in ("index", "method", "project-file", "performance", "porting"):
        assert (site / page / "index.html").is_file() or page == "index"
    assert (site / "index.html").is_file()


def python_blocks(page: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (DOCS / page).read_text(encoding="utf-8"), flags=re.S)


def test_getting_started_and_porting_examples_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for page in ("index.md", "porting.md"):
        blocks = python_blocks(page)
        assert blocks, page
        namespace: dict = {}
        for block in blocks:
            exec(compile(block, str(DOCS / page), "exec"), namespace)


def test_project_file_reference_has_one_home():
    # The reference lives in docs/; the examples folder only points to it.
    pointer = (ROOT / "python" / "edmf_rs" / "examples" / "projects" / "README.md").read_text(encoding="utf-8")
    assert "docs/project-file.md" in pointer and "[[uncertainty]]" not in pointer
    reference = (DOCS / "project-file.md").read_text(encoding="utf-8")
    for key in ("[identification]", "[parameters.", "[sampling]", "[model]", "[measurements]", "[[uncertainty]]",
                "[[prognosis]]", "relative_to", "correction"):
        assert key in reference, key


def test_readme_links_to_the_docs():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for link in ("docs/index.md", "docs/performance.md", "docs/project-file.md", "mkdocs serve"):
        assert link in readme, link
