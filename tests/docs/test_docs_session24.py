"""The README's and the docs' claims fixed in session 24, each held to the code or to the recorded run
it comes from: how the thresholds of a non-normal U_c are computed (convolution by default, Monte Carlo
only where a source cannot be convolved), every key the project-file readers accept documented on
docs/project-file.md, the least-squares rates with weights="sigma", the streaming memory figures, the
CI command and the dotted names the pages give."""

from __future__ import annotations

import ast
import importlib
import inspect
import math
import re

import numpy as np
import pytest
from api_pages import ROOT, resolve
from scipy import stats

import edmf_rs
from edmf_rs.engine import convolution, mc_intervals

README = ROOT / "README.md"
DOCS = ROOT / "docs"


def flat(path) -> str:
    """The file's text with every run of whitespace one space (sentences wrap anywhere)."""
    return " ".join(path.read_text(encoding="utf-8").split())


# -- thresholds of a non-normal U_c ---------------------------------------------------------------

def grid_claims() -> list[str]:
    """The convolution's accuracy and applicability as the pages state them, from the module's constants."""
    exponent = round(math.log10(convolution.TOLERANCE))
    assert convolution.TOLERANCE == 10.0**exponent
    superscript = str(exponent).translate(str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹"))
    cells = round(math.log2(convolution.MAX_CELLS))
    assert convolution.MAX_CELLS == 2**cells
    tail = round(math.log10(convolution.TAIL))
    assert convolution.TAIL == 10.0**tail
    tail = str(tail).translate(str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹"))
    return [f"less than 10{superscript} of the interval's width (at most 2^{cells}",
            f"no finite 10{tail}", f"more than {convolution.MAX_SPAN_IQR:,.0f} interquartile ranges"]


def test_the_defaults_the_pages_state_are_the_code():
    bounds = inspect.signature(edmf_rs.threshold_bounds).parameters
    assert bounds["method"].default == "convolution" and bounds["estimator"].default == "conservative"
    combine = inspect.signature(edmf_rs.combine).parameters
    assert combine["n_samples"].default == 200_000 and combine["seed"].default == 0
    assert mc_intervals.DEFAULT_CONFIDENCE == 0.975 and mc_intervals.MIN_TAIL == 100
    readme = flat(README)
    assert "(200,000 and seed 0 by default, recorded on the result)" in readme
    assert "with confidence 0.975" in readme and "fewer than 100 samples per tail" in readme
    for page in (readme, flat(DOCS / "method.md"), flat(DOCS / "project-file.md")):
        for claim in grid_claims():
            assert claim in page, claim
    assert "(200,000 by default, seed 0)" in flat(DOCS / "method.md")


def test_exact_convolution_and_monte_carlo_are_chosen_per_sensor():
    """Three sensors: all-normal sources (exact), a uniform among them (convolution), a Cauchy (samples)."""
    model = [[stats.norm(0, 1), stats.uniform(-1, 2), stats.cauchy(0, 0.1)]]  # one source, per sensor
    combined = edmf_rs.combine(model=model, measurement=stats.norm(0, 0.1), n_samples=20_000)
    assert combined.samples.shape == (20_000, 3)  # drawn over every sensor, exact ones included
    t = edmf_rs.threshold_bounds(combined, phi=0.95)
    assert t.method == ("exact", "convolution", "central")
    width = t.high[1] - t.low[1]
    assert 0 < t.se_low[1] <= convolution.TOLERANCE * width and t.se_low[0] == 0
    # the exact sensor's bound ignores its samples: the closed form of N(0, sqrt(1.01))
    assert t.high[0] == pytest.approx(stats.norm(0, math.sqrt(1.01)).ppf(0.5 + t.probability / 2))
    plain = edmf_rs.threshold_bounds(combined, phi=0.95, estimator="shortest")
    assert plain.method == ("exact", "shortest-plain", "shortest-plain")
    mc = edmf_rs.threshold_bounds(combined, phi=0.95, method="monte-carlo")
    assert mc.method == ("exact", "central", "central")


def test_what_cannot_be_convolved_is_what_the_pages_say():
    noise = (-1.0, stats.norm(0, 1))
    assert not convolution.convolvable([(1.0, stats.cauchy()), noise])
    assert not convolution.convolvable([(1.0, stats.t(3)), noise])
    assert convolution.convolvable([(1.0, stats.t(5)), noise])
    assert convolution.convolvable([(1.0, stats.uniform(-1, 2)), noise])
    assert "e.g. Cauchy, or Student t with 3 degrees of freedom or fewer" in flat(DOCS / "project-file.md")
    assert "e.g. Cauchy: `edmf_rs.engine.convolution.convolvable`" in flat(README)


def test_porting_central_where_symmetric_shortest_where_skewed():
    """docs/porting.md: a uniform source added to a normal is symmetric (central interval, Eq. 6);
    a triangular source with its mode off centre is skewed (the shortest, narrower than the central)."""
    noise = stats.norm(0, 0.1)
    sym = edmf_rs.combine(model=stats.uniform(-0.05, 0.25), measurement=noise, n_sensors=1, n_samples=10_000)
    t = edmf_rs.threshold_bounds(sym)
    mean = stats.uniform(-0.05, 0.25).mean()
    assert sym.symmetric.all() and t.method == ("convolution",)
    assert t.high[0] - mean == pytest.approx(mean - t.low[0], rel=1e-3)
    tri = stats.triang(0.0, loc=-0.5, scale=1.5)  # mode at the lower edge
    skew = edmf_rs.combine(model=tri, measurement=stats.norm(0, 0.05), n_sensors=1, n_samples=100_000)
    s = edmf_rs.threshold_bounds(skew)
    assert not skew.symmetric.any() and s.method == ("convolution",)
    central = np.quantile(skew.samples[:, 0], [0.5 - s.probability / 2, 0.5 + s.probability / 2])
    assert s.high[0] - s.low[0] < 0.98 * (central[1] - central[0])  # 2.7 % narrower; sampling noise ~0.3 %
    page = flat(DOCS / "porting.md")
    assert "symmetric unimodal U_c (every normal case, a uniform source added to a normal) the two coincide, and " \
           "edmf_rs takes the central one (Eq. 6); for skewed U_c (a triangular source with its mode off centre" in page


def test_the_girder_is_convolution_at_the_deflections_and_exact_at_the_gauges():
    from edmf_rs import cli

    project = edmf_rs.Project.from_toml(cli.EXAMPLES / "girder.toml")
    t = edmf_rs.threshold_bounds(project.combined_uncertainty(), project.phi, project.correction)
    methods = dict(zip(project.sensor_names, t.method))
    assert methods == {"D1": "convolution", "D2": "convolution", "D3": "convolution",
                       **{f"SG{i}": "exact" for i in range(1, 8)}}
    page = flat(DOCS / "project-file.md")
    assert "in `girder.toml` the uniform source covers D1-D3, whose bounds come from convolution, while SG1-SG7 " \
           "stay exact" in page
    assert ('`{"exact": ["SG1", ..., "SG7"], "convolution": ["D1", "D2", "D3"]}`') in page


def test_no_page_says_monte_carlo_where_the_code_convolves():
    readme, project_file = flat(README), flat(DOCS / "project-file.md")
    method = flat(DOCS / "method.md")
    assert "Monte Carlo elsewhere" not in readme
    assert "only for the others" not in readme
    assert "Monte Carlo otherwise" not in project_file and "Monte Carlo combined uncertainty" not in project_file
    assert "makes U_c Monte Carlo" not in project_file
    assert "otherwise it is Monte Carlo samples of U_c" not in method
    assert "or a non-normal [`combine`](api.md#edmf_rs.combine) result: Eq. 5 directly" not in method


# -- every key of the project files -------------------------------------------------------------

#: (module, reading function) -> the heading of docs/project-file.md documenting the table it reads.
READERS = {
    ("edmf_rs.project.identification", "identification"): "`[identification]`",
    ("edmf_rs.project.schema", "_parameters"): "`[parameters.NAME]`",
    ("edmf_rs.project.schema", "_sampling"): "`[sampling]`",
    ("edmf_rs.project.adaptive", "adaptive_sampling"): "`[sampling]`",
    ("edmf_rs.project.schema", "_model"): "`[model]`",
    ("edmf_rs.project.schema", "_command"): "`[model]`",
    ("edmf_rs.project.schema", "_compute"): "`[compute]`",
    ("edmf_rs.project.schema", "_measurements"): "`[measurements]`",
    ("edmf_rs.project.schema", "_uncertainty"): "`[[uncertainty]]`",
    ("edmf_rs.project.schema", "_prognosis"): "`[[prognosis]]`",
    ("edmf_rs.project.schema", "read_spec"): None,  # the top-level tables
    ("edmf_rs.design.project", "read_design_project"): "`[design]`",
}


def _keys(node, module) -> tuple[str, ...] | None:
    """The string keys of a check_keys argument (constants, module-level tuples, starred ones); None if computed."""
    if isinstance(node, ast.Name):
        return tuple(getattr(module, node.id))
    if not isinstance(node, (ast.Tuple, ast.List)):
        return None
    keys: list[str] = []
    for elt in node.elts:
        if isinstance(elt, ast.Constant) and isinstance(elt.value, str):
            keys.append(elt.value)
        elif isinstance(elt, ast.Starred) and isinstance(elt.value, ast.Name):
            keys.extend(getattr(module, elt.value.id))
        else:
            return None
    return tuple(keys)


def accepted_keys() -> list[tuple[str, str, str, tuple[str, ...] | None]]:
    """(module, innermost function, receiver, keys) of every ``check_keys`` call of the readers."""
    found = []
    for name in sorted({m for m, _ in READERS}):
        module = importlib.import_module(name)

        class Calls(ast.NodeVisitor):
            stack: list[str] = []

            def visit_FunctionDef(self, node):
                self.stack.append(node.name)
                self.generic_visit(node)
                self.stack.pop()

            def visit_Call(self, node):
                if isinstance(node.func, ast.Attribute) and node.func.attr == "check_keys":
                    found.append((name, self.stack[-1], ast.unparse(node.func.value), _keys(node.args[0], module)))
                self.generic_visit(node)

        Calls().visit(ast.parse(inspect.getsource(module)))
    return found


def sections(text: str) -> dict[str, str]:
    parts = re.split(r"^## (.+)$", text, flags=re.M)
    return {title.strip(): body for title, body in zip(parts[1::2], parts[2::2])}


def documented(key: str, text: str) -> bool:
    """``key`` in backticks (alone or as ``key = ...``), or the last part of a backticked table header."""
    tokens = re.findall(r"`([^`]+)`", text)
    return any(t == key or t.startswith(f"{key} = ") or t.strip("[]").split(".")[-1] == key for t in tokens)


def test_every_key_the_readers_accept_is_on_the_project_file_page():
    calls = accepted_keys()
    assert {(m, f) for m, f, _, _ in calls} == set(READERS), "a new reader: add its table to READERS and the page"
    text = (DOCS / "project-file.md").read_text(encoding="utf-8")
    pages = sections(text)
    missing = []
    for module, function, receiver, keys in calls:
        if keys is None:  # computed (the parameter names of sampling.points)
            continue
        if receiver == "root":
            missing += [f"top-level [{k}]" for k in keys if f"[{k}]" not in text and f"[{k}." not in text
                        and f"[[{k}]]" not in text]
            continue
        body = pages.get(READERS[module, function], "")  # no such section: every key is missing
        missing += [f"{READERS[module, function]} {k}" for k in keys if not documented(k, body)]
    assert not missing, missing


def test_the_page_says_it_gives_every_key_and_the_adaptive_refusal():
    page = flat(DOCS / "project-file.md")
    assert "The sections below give every key, its default and what it must be." in page
    assert "An adaptive project is refused with `[compute] scheduler`" in page
    from edmf_rs.project.adaptive import AdaptiveSampling

    defaults = {f: AdaptiveSampling.__dataclass_fields__[f].default for f in ("n_screen", "c", "seed", "basis")}
    assert defaults == {"n_screen": 2**20, "c": 3.0, "seed": 0, "basis": "auto"}
    assert "| `n_screen` | `1_048_576` (2^20) |" in page and "| `c` | `3.0` |" in page
    assert "| `budget` | 40 × n_params + 200 |" in page and "| `basis` | `\"auto\"` |" in page
    source = inspect.getsource(importlib.import_module("edmf_rs.project.adaptive").adaptive_sampling)
    assert 'count("budget", 40 * p + 200)' in source
    waves = inspect.getsource(importlib.import_module("edmf_rs.adaptive.waves").adaptive_falsify)
    assert "n_initial = 20 * p if n_initial is None" in waves and "wave_size = 10 * p if wave_size is None" in waves
    assert "| `n_initial` | 20 × n_params |" in page and "| `wave_size` | 10 × n_params |" in page


def test_the_model_and_measurement_defaults_on_the_page_are_the_specs():
    from edmf_rs.project.schema import ModelSpec, ProjectSpec

    model = {f: ModelSpec.__dataclass_fields__[f].default
             for f in ("workers", "store", "stop_after_failures", "max_failure_rate", "batch_size", "nan")}
    assert model == {"workers": 1, "store": True, "stop_after_failures": 5, "max_failure_rate": None,
                     "batch_size": 10_000, "nan": "raise"}
    spec = {f: ProjectSpec.__dataclass_fields__[f].default for f in ("decimal", "encoding")}
    assert spec == {"decimal": ".", "encoding": "utf-8"}
    page = flat(DOCS / "project-file.md")
    for row in ("| `workers` | `1` |", "| `store` | `true` |", "| `stop_after_failures` | `5` |",
                "| `max_failure_rate` | none |", "| `keep_work` | `false` |", "| `timeout` | none |",
                "| `output` | `\"results.csv\"` |", "| `files` | `[]` |", "| `decimal` | `\".\"` |",
                "| `encoding` | `\"utf-8\"` |", "| `k` | the number of candidates |", "| `n_simulations` | `1000` |",
                "| `fixed` | `[]` |"):
        assert row in page, row
    design = inspect.getsource(importlib.import_module("edmf_rs.design.project").read_design_project)
    assert 't.get("k", "int", len(candidates)' in design and 't.get("n_simulations", "int", 1000' in design


def test_top_level_sensors_are_an_alias_of_measurements_sensors(tmp_path):
    from _projects import LINEAR_MODEL, project_text, write_project

    body = project_text(parameters={"a": (0.0, 2.0), "b": (0.0, 2.0)}, sampling={"method": "grid",
                        "points": {"a": 3, "b": 3}}, model={"function": "linmodel:predict"},
                        sensors=[{"name": f"S{i}", "value": v} for i, v in ((1, 1.3), (2, 1.8))],
                        uncertainty=({"name": "noise", "kind": "measurement", "distribution": "normal", "sd": 0.1},))
    body += "\n[[sensors]]\nname = \"S3\"\nvalue = 2.0\n\n[[sensors]]\nname = \"S4\"\nvalue = -0.2\n"
    path = write_project(tmp_path, body, modules={"linmodel": LINEAR_MODEL})
    assert edmf_rs.Project.from_toml(path).sensor_names == ("S1", "S2", "S3", "S4")
    assert "top-level `[[sensors]]` tables are the same (an alias; both may be used, their sensors joined)" in \
        flat(DOCS / "project-file.md")


# -- the README's numbers ---------------------------------------------------------------------------

def test_least_squares_with_sigma_weights_rates_are_the_reproduction_draws():
    """The rates of weights="sigma" over the reproduction's own scenario-1 draws and rule."""
    from edmf_rs.paper import cantilever as cl
    from edmf_rs.paper import reproduce as rp
    from edmf_rs.paper.baselines import least_squares

    scenario = cl.SCENARIOS[0]
    assert scenario.number == 1
    rates = []
    for n_m in cl.N_SENSORS:
        _, g, _ = rp._setup(n_m)
        correct = 0
        for y in rp.measurement_draws(scenario, n_m, 200, 0):
            _, sd = cl.combined_moments(scenario, y)
            assert np.allclose(sd, 0.02)  # scenario 1: the sensor noise only
            r = least_squares(g, y, weights="sigma", sigma=sd, parameters=cl.E_GRID)
            correct += abs(cl.E_GRID[r.index] - cl.E_TRUE) <= rp.LS_TOLERANCE * cl.E_TRUE
        rates.append(correct / 200)
    assert cl.N_SENSORS == (1, 2, 10, 50)
    readme = flat(README)
    assert (f"the same 200 scenario-1 draws give correct rates of {' / '.join(f'{r:.3f}' for r in rates)} at "
            f"n_m = 1 / 2 / 10 / 50") in readme
    assert "it is always correct" not in readme


def test_the_streaming_memory_is_the_results_file():
    text = (ROOT / "benches" / "results-streaming.txt").read_text(encoding="utf-8")
    m = re.search(r"peak RSS of a process running edmf_rs.falsify on the file: (\d+) MiB "
                  r"\(of which (\d+) MiB just importing edmf_rs\); the file is ([\d,]+) MiB", text)
    peak, imports, size = int(m[1]), int(m[2]), int(m[3].replace(",", ""))
    assert round(size / 1024) == 6
    readme = flat(README)
    assert f"peak RSS {peak} MiB for a 6 GiB file, {imports} MiB of it importing edmf_rs" in readme
    assert f"streams a 6 GiB `.npy` file in {peak} MiB of memory" in readme
    performance = flat(DOCS / "performance.md")
    assert f"Peak RSS of the process falsifying the 6 GiB file: {peak} MiB ({imports} MiB of it" in performance


# -- commands and names -----------------------------------------------------------------------------

def test_the_getting_started_page_gives_the_ci_command():
    command = (ROOT / ".ci" / "run").read_text(encoding="utf-8").strip().splitlines()[-1]
    assert command in (DOCS / "index.md").read_text(encoding="utf-8")
    assert command in README.read_text(encoding="utf-8")


@pytest.mark.parametrize("page", ["README.md", "docs/index.md", "docs/method.md", "docs/project-file.md",
                                  "docs/porting.md"])
def test_every_dotted_name_the_page_gives_exists(page):
    names = set(re.findall(r"`(edmf_rs(?:\.\w+)+)", (ROOT / page).read_text(encoding="utf-8")))
    assert page != "README.md" or "edmf_rs.engine.borderline.borderline_instances" in names
    unresolved = []
    for name in sorted(names):
        try:
            resolve(name)
        except (ImportError, AttributeError):
            unresolved.append(name)
    assert not unresolved, unresolved


def test_the_method_page_keeps_the_diagnostics_its_own():
    method = flat(DOCS / "method.md")
    quote = "it is possible to review the model class and assumptions initially chosen"  # the paper, Sec. 3.3
    assert f'"{quote}"' in method and "edmf_rs's own diagnostics" in method
    assert "the paper's Sec. 3.3 asks for" not in method
