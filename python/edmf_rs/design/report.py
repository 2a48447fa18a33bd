"""Outputs of ``edmf-rs design``: design.json, design.csv, plots and an HTML
report, each written atomically (a failed run never leaves a complete-looking file)."""

from __future__ import annotations

import csv
import html
import io
import json
from pathlib import Path

import numpy as np

from ..stream.atomic import write_bytes, write_text


def rows(project, design, curve) -> list[dict]:
    """One row per chosen sensor: order, location, H and expected identifiability."""
    out = []
    for m, i in enumerate(design.order.tolist()):
        c = project.candidates[i]
        out.append({
            "step": m + 1, "index": i, "name": c.name, "type": c.type, "location": c.location,
            "load_case": c.load_case, "cost": c.cost, "cumulative_cost": float(design.cost[m]),
            "joint_entropy": float(design.joint_entropy[m]),
            "mean_candidates": float(curve.mean[m]), "median_candidates": float(curve.median[m]),
            "p95_candidates": float(curve.p95[m]),
            "mean_fraction": float(curve.mean[m] / curve.n_instances),
        })
    return out


def plot_names(project) -> list[str]:
    """The plots :func:`write_plots` writes for ``project`` (the locations' only when some candidate has one)."""
    located = any(c.location is not None for c in project.candidates)
    return ["design_curves.png"] + (["design_locations.png"] if located else [])


def outputs(project) -> list[str]:
    """Every file a design of ``project`` writes into ``--out`` (design.json records them: a rerun
    removes those an earlier design of the same project wrote and it does not)."""
    return ["design.json", "design.csv", *plot_names(project), "report.html"]


def write_json(out: Path, project, design, curve, widths, elapsed: float) -> None:
    doc = {
        "project": str(project.file), "name": project.name, "n_instances": int(design.n_instances),
        "n_candidates": len(project.candidates), "k": project.k, "budget": project.budget,
        "phi": project.phi, "correction": project.correction, "n_simulations": project.n_simulations,
        "best_n_sensors": curve.best, "seconds": round(elapsed, 3),
        "widths": {c.name: float(w) for c, w in zip(project.candidates, widths)},
        "sensors": rows(project, design, curve),
        "references": [
            "Papadopoulou, Raphael, Smith & Sekhar (2014) Entropy 16(9):5078",
            "Bertola, Papadopoulou, Vernay & Smith (2017) Sensors 17(12):2904",
            "Goulet & Smith (2013) J. Struct. Eng. 139(10)",
        ],
        "outputs": outputs(project),
    }
    write_text(out / "design.json", json.dumps(doc, indent=2) + "\n")


def write_csv(out: Path, project, design, curve) -> None:
    """design.csv: one row per chosen sensor, CSV-quoted (a name may hold a comma or a quote)."""
    table = rows(project, design, curve)
    keys = list(table[0]) if table else ["step"]
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(keys)
    writer.writerows(["" if r[k] is None else str(r[k]) for k in keys] for r in table)
    write_text(out / "design.csv", buf.getvalue())


def _png(fig) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def write_plots(out: Path, project, design, curve) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = np.arange(1, len(design) + 1)
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.8))
    ax[0].plot(m, design.joint_entropy, "o-")
    ax[0].axhline(np.log2(design.n_instances), ls=":", c="grey", label="log2 N")
    ax[0].set(xlabel="number of sensors", ylabel="joint entropy H (bits)", title="Information")
    ax[0].legend()
    ax[1].plot(m, curve.mean, "o-", label="mean")
    ax[1].plot(m, curve.median, "s--", label="median")
    ax[1].plot(m, curve.p95, "^:", label="95th percentile")
    ax[1].axvline(curve.best, c="grey", ls=":")
    ax[1].set(xlabel="number of sensors", ylabel="expected candidate-set size", title="Expected identifiability")
    ax[1].legend()
    write_bytes(out / "design_curves.png", _png(fig))
    names = plot_names(project)
    located = [c for c in project.candidates if c.location is not None]
    if located:
        cases = sorted({c.load_case for c in project.candidates})
        types = sorted({c.type for c in project.candidates})
        fig, ax = plt.subplots(figsize=(10, 1.2 + 0.5 * len(cases) * len(types)))
        lanes = {(case, t): j for j, (case, t) in enumerate((c, t) for c in cases for t in types)}
        for c in located:
            ax.plot(c.location, lanes[(c.load_case, c.type)], "|", c="lightgrey", ms=12)
        for step, i in enumerate(design.order.tolist(), start=1):
            c = project.candidates[i]
            if c.location is not None:
                y = lanes[(c.load_case, c.type)]
                ax.plot(c.location, y, "o", c="C3")
                ax.annotate(str(step), (c.location, y), textcoords="offset points", xytext=(0, 6), ha="center")
        ax.set_yticks(list(lanes.values()), [f"{t} {case}".strip() for case, t in lanes])
        ax.set(xlabel="location", title="Chosen sensors (numbered in order of choice) among the candidates")
        ax.set_ylim(-0.7, len(lanes) - 0.3)
        write_bytes(out / "design_locations.png", _png(fig))
    return names


def write_html(out: Path, project, design, curve, plots: list[str]) -> None:
    esc = html.escape
    head = ["step", "name", "type", "location", "load case", "cost", "H (bits)", "mean |candidates|",
            "median", "95 %"]
    body = "".join(
        "<tr>" + "".join(f"<td>{esc(str(v))}</td>" for v in (
            r["step"], r["name"], r["type"], r["location"], r["load_case"], r["cost"],
            f"{r['joint_entropy']:.3f}", f"{r['mean_candidates']:.1f}", f"{r['median_candidates']:.0f}",
            f"{r['p95_candidates']:.0f}")) + "</tr>"
        for r in rows(project, design, curve))
    images = "".join(f'<p><img src="{esc(p)}" alt="{esc(p)}"></p>' for p in plots)
    text = f"""<!doctype html><html><head><meta charset="utf-8"><title>{esc(project.name)}: sensor design</title>
<style>body{{font-family:sans-serif;max-width:1000px;margin:auto}}td,th{{padding:2px 8px;text-align:right}}</style>
</head><body><h1>{esc(project.name)}: measurement-system design</h1>
<p>{esc(project.description)}</p>
<p>{design.n_instances} model instances, {len(project.candidates)} candidate locations. Sensors chosen greedily by
joint entropy of the binned predictions (Papadopoulou et al. 2014; Bertola et al. 2017){' per unit cost' if project.budget else ''};
expected candidate-set sizes from {project.n_simulations} simulated measurements (Goulet &amp; Smith 2013, Eqs. 4-8,
phi = {project.phi}, {esc(project.correction)}). The smallest mean candidate set is reached with
<b>{curve.best}</b> sensors; beyond that, the wider thresholds of more sensors cost more than their information.</p>
<table><tr>{''.join(f'<th>{h}</th>' for h in head)}</tr>{body}</table>{images}</body></html>
"""
    write_text(out / "report.html", text)
