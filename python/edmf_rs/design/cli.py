"""``edmf-rs design PROJECT.toml --out DIR``: choose sensor locations for a
design project (see :mod:`edmf_rs.design.project`) and write design.json,
design.csv, plots and report.html to DIR."""

from __future__ import annotations

import time
from pathlib import Path

from . import report
from .entropy import interval_widths
from .identifiability import identifiability_curve
from .placement import place_sensors
from .project import read_design_project


def run_design(project_path, out=None) -> dict:
    """Runs a design project; returns the paths written."""
    start = time.perf_counter()
    project = read_design_project(project_path)
    out = Path(out) if out is not None else Path(project.file).parent / f"{Path(project.file).stem}-out"
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
    report.write_json(out, project, design, curve, widths, elapsed)
    report.write_csv(out, project, design, curve)
    plots = report.write_plots(out, project, design, curve)
    report.write_html(out, project, design, curve, plots)
    return {"out": out, "design": design, "curve": curve}


def design_cli(project_path, out=None) -> int:
    result = run_design(project_path, out)
    d, c = result["design"], result["curve"]
    print(f"{len(d)} sensors chosen: " + ", ".join(str(i) for i in d.order.tolist()))
    print(f"joint entropy {d.joint_entropy[-1]:.3f} bits; smallest mean candidate set with {c.best} sensors "
          f"({c.mean[c.best - 1]:.1f} of {c.n_instances})")
    print(f"written to {result['out']}")
    return 0
