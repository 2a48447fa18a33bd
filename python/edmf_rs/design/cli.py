"""``edmf-rs design PROJECT.toml --out DIR``: choose sensor locations for a
design project (see :mod:`edmf_rs.design.project`) and write design.json,
design.csv, plots and report.html to DIR.

``--out`` is refused as ``edmf-rs run`` refuses it (a file; a non-empty
folder that holds no earlier design of the project, unless ``--force``), and
an output never replaces an input of the project, even with ``--force``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from ..project.command import MARKER, check_out
from ..stream.atomic import write_text
from . import report
from .entropy import interval_widths
from .identifiability import identifiability_curve
from .placement import place_sensors
from .project import DesignProject, read_design_project

#: Every file a design writes into ``--out``.
OUTPUT_FILES = ("design.json", "design.csv", "design_curves.png", "design_locations.png", "report.html", MARKER)

HELP = """\
Choose sensor locations before the test from a project file with a [design] table: joint-entropy
placement of the candidate locations (per unit cost, within a budget) and the expected
candidate-set size after each sensor. Writes design.json, design.csv, plots and report.html."""


def add_parser(sub, common) -> None:
    """The ``design`` subcommand of ``edmf-rs``."""
    cmd = sub.add_parser("design", parents=[common], description=HELP, help="choose sensor locations before the "
                         "test: joint-entropy placement and expected identifiability (a project with [design])")
    cmd.add_argument("project", help="design project file, e.g. girder-design.toml")
    cmd.add_argument("--out", default=None,
                     help="output folder (default: PROJECT-out next to the project file); refused when not empty "
                          "unless it holds an earlier design of the same project")
    cmd.add_argument("--force", action="store_true",
                     help="write into a non-empty --out folder (inputs of the project are never overwritten)")


def _earlier_design(out: Path, project: DesignProject) -> bool:
    """design.json of this project (written before designs left the run marker)."""
    try:
        doc = json.loads((out / "design.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and doc.get("name") == project.name \
        and Path(str(doc.get("project"))).name == project.file.name


def check_design_out(out: Path, project: DesignProject, force: bool) -> None:
    """Refuses an output folder the design must not write into (see the module docstring).

    Raises
    ------
    ProjectError
        ``out`` is a file; a non-empty folder that holds no earlier design of
        this project (without ``force``); or an output would replace an input.
    """
    check_out(out, project, force or _earlier_design(out, project), outputs=(*report.outputs(project), MARKER),
              what="design")


def _earlier_outputs(out: Path, project: DesignProject) -> set[str]:
    """The outputs an earlier design of this same project wrote into ``out``, as its
    design.json records them: only when the run marker names this project file,
    and only names of design outputs (never another file of the folder)."""
    try:
        if (out / MARKER).read_text(encoding="utf-8").strip() != str(project.file.resolve()):
            return set()
        doc = json.loads((out / "design.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    listed = doc.get("outputs") if isinstance(doc, dict) else None
    if not isinstance(listed, list):
        return set()
    return {name for name in listed if isinstance(name, str)} & set(OUTPUT_FILES) - {MARKER, "design.json"}


def run_design(project_path, out=None, *, force: bool = False) -> dict:
    """Runs a design project; returns the paths written."""
    start = time.perf_counter()
    project = read_design_project(project_path)
    out = Path(out) if out is not None else Path(project.file).parent / f"{Path(project.file).stem}-out"
    check_design_out(out, project, force)
    g = project.predictions()
    combined = project.combined_uncertainty(g)
    widths = interval_widths(combined, project.k, project.phi, project.correction)
    design = place_sensors(g, widths, project.k, fixed=project.fixed, costs=project.costs,
                           types=[c.type for c in project.candidates], budget=project.budget,
                           tolerance=project.tolerance, max_per_type=project.max_per_type)
    if len(design) == 0:
        raise ValueError(f"{project.file}: design: no sensor was chosen (tolerance too high?)")
    curve = identifiability_curve(g, combined, design.order, n_simulations=project.n_simulations,
                                  phi=project.phi, correction=project.correction, seed=project.seed)
    elapsed = time.perf_counter() - start
    # An earlier design's outputs that this one does not write (a plot of locations the candidates
    # no longer have) go first, while design.json still records them.
    for name in sorted(_earlier_outputs(out, project) - set(report.outputs(project))):
        (out / name).unlink(missing_ok=True)
    write_text(out / MARKER, str(project.file.resolve()) + "\n")  # the folder is this project's from now on
    report.write_json(out, project, design, curve, widths, elapsed)
    report.write_csv(out, project, design, curve)
    plots = report.write_plots(out, project, design, curve)
    report.write_html(out, project, design, curve, plots)
    return {"out": out, "design": design, "curve": curve}


def design_cli(project_path, out=None, force: bool = False) -> int:
    result = run_design(project_path, out, force=force)
    d, c = result["design"], result["curve"]
    print(f"{len(d)} sensors chosen: " + ", ".join(str(i) for i in d.order.tolist()))
    print(f"joint entropy {d.joint_entropy[-1]:.3f} bits; smallest mean candidate set with {c.best} sensors "
          f"({c.mean[c.best - 1]:.1f} of {c.n_instances})")
    print(f"written to {result['out']}")
    return 0
