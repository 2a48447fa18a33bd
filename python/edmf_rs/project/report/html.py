"""The HTML report of an identification: one self-contained page (inline CSS,
figures embedded as base64 PNG, no external assets or scripts)."""

from __future__ import annotations

import base64
from html import escape

from ... import __version__
from ..format import in_domain, number, plural

CSS = """
body { font-family: -apple-system, "Segoe UI", Helvetica, Arial, sans-serif; margin: 2em auto; max-width: 1100px;
       color: #222; line-height: 1.45; padding: 0 1em; }
h1 { margin-bottom: 0.1em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 1.8em; }
.sub { color: #666; margin-top: 0; }
.verdict { padding: 0.8em 1.2em; border-radius: 6px; font-size: 1.15em; margin: 1em 0; }
.ok { background: #e8f3ea; border-left: 6px solid #2e7d32; }
.bad { background: #fbeaea; border-left: 6px solid #c0392b; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.9em; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: right; }
th { background: #f3f3f3; } td.l, th.l { text-align: left; }
tr.suspect td { background: #fbeaea; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { color: #555; font-size: 0.9em; }
.notes { color: #444; font-size: 0.9em; }
"""


def render(ident, figures: dict[str, bytes]) -> str:
    """The report page for ``ident`` (an Identification) with its ``figures`` (PNG bytes by name)."""
    p = ident.project
    parts = [
        "<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
        f"<title>EDMF report: {escape(p.name)}</title><style>{CSS}</style></head><body>",
        f"<h1>{escape(p.name)}</h1>",
        f"<p class='sub'>Error-domain model falsification (Goulet &amp; Smith 2013) of <code>{escape(p.file.name)}</code>"
        f" with edmf_rs {escape(__version__)}</p>",
    ]
    if p.description:
        parts.append(f"<p>{escape(p.description)}</p>")
    parts.append(_verdict(ident))
    parts.append("<ul>" + "".join(f"<li>{escape(text)}</li>" for text in ident.findings()) + "</ul>")
    parts += ["<h2>Parameters</h2>", _parameters(ident)]
    if p.prognosis:
        parts += ["<h2>Prognosis</h2>", _prognosis(ident)]
    parts += [
        "<h2>Sensors and threshold bounds</h2>", _thresholds(ident),
        _figure(figures, "leave_one_out",
                "Leave one sensor out: the candidate set size when each sensor is ignored, from the same pass "
                "(candidates + instances falsified by that sensor alone)."),
        _figure(figures, "residuals",
                "Residuals g(θ) − y of the candidates, and of a sample of falsified instances, scaled so that each "
                "sensor's threshold bounds are at ±1."),
        "<h2>Candidate model set</h2>",
        _figure(figures, "scatter_matrix", "Parameters of the candidates over the falsified instances (sample)."),
        _figure(figures, "parallel_coordinates", "Each candidate as a line through its parameter values."),
        "<h2>Sensitivity</h2>",
        _figure(figures, "sensitivity",
                "Candidate set size against a scale factor s on the spread of every uncertainty (left) "
                "and against the target identification probability φ (right)."),
        "<h2>Uncertainty sources</h2>", _sources(ident),
        "<h2>Settings</h2>", _settings(ident), _notes(),
        "</body></html>",
    ]
    return "\n".join(parts)


def _verdict(ident) -> str:
    return _verdict_text(ident) + _evaluation(ident)


def _verdict_text(ident) -> str:
    r = ident.falsification
    invalid = r.n_invalid or 0  # NaN predictions: neither candidates nor falsified
    valid = r.n_instances - invalid
    apart = (f" {invalid:,} of the {plural(r.n_instances, 'instance')} {'is' if invalid == 1 else 'are'} invalid "
             "(NaN predictions: neither candidates nor falsified).") if invalid else ""
    if r.model_class_falsified and not valid:
        return (f"<div class='verdict bad'><b>No candidate model, and nothing falsified</b>: "
                f"{'the' if r.n_instances == 1 else 'all'} {plural(r.n_instances, 'model instance')} "
                f"{'is' if r.n_instances == 1 else 'are'} invalid (their predictions hold NaN), so none could be "
                "compared with the measurements.</div>")
    if r.model_class_falsified:
        every = "the" if valid == 1 else "all"
        return (f"<div class='verdict bad'><b>Model class falsified</b>: {every} "
                f"{plural(valid, 'valid model instance' if invalid else 'model instance')} "
                f"{'is' if valid == 1 else 'are'} falsified by the measurements.{apart}</div>")
    share = 100.0 * r.n_candidates / r.n_instances
    return (f"<div class='verdict ok'><b>{plural(r.n_candidates, 'candidate model')}</b> of "
            f"{plural(r.n_instances, 'instance')} ({share:.3g} %).{apart}</div>")


def _evaluation(ident) -> str:
    """Model runs: evaluated now, reused from the prediction store, failed (neither candidates nor falsified)."""
    ev = ident.evaluation
    if not ev:
        return ""
    text = (f"<p>Model evaluations: {ev['model_evaluations']:,}; reused from the prediction store: "
            f"{ev['reused_evaluations']:,}.")
    if ev["failed_instances"]:
        text += (f" <b>Failed model runs: {ev['failed_instances']:,}</b> (neither candidates nor falsified; "
                 "reasons, stderr and work folders in failures.csv).")
    return text + "</p>"


def _table(header: list[str], rows: list[list], left: int = 1, row_class=None) -> str:
    th = "".join(f"<th class='{'l' if i < left else ''}'>{escape(h)}</th>" for i, h in enumerate(header))
    body = []
    for k, row in enumerate(rows):
        cls = f" class='{row_class(k)}'" if row_class and row_class(k) else ""
        tds = "".join(f"<td class='{'l' if i < left else ''}'>{escape(_fmt(v))}</td>" for i, v in enumerate(row))
        body.append(f"<tr{cls}>{tds}</tr>")
    return f"<table><tr>{th}</tr>{''.join(body)}</table>"


def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int) or (hasattr(v, "dtype") and v.dtype.kind in "iu"):
        return f"{int(v):,}"
    if isinstance(v, float) or hasattr(v, "dtype"):
        return "" if v != v else number(v, 5)
    return str(v)


def _parameters(ident) -> str:
    rows = []
    for param, span in zip(ident.project.parameters, ident.parameter_ranges().values()):
        shown = [in_domain(v, param.low, param.high, 5) for v in (param.low, param.high, *(span or ()))]
        rows.append([param.name, param.unit, param.scale, *shown, *(() if span else ("–", "–"))])
    return _table(["parameter", "unit", "scale", "domain low", "domain high", "candidates min", "candidates max"],
                  rows, left=3)


def _prognosis(ident) -> str:
    if not ident.prognoses:
        return "<p>No prognosis: the model class is falsified, so there is no candidate to predict with.</p>"
    rows = [[g.name, g.unit, g.model_low, g.model_high,
             f"[{g.uncertainty_interval[0]:.4g}, {g.uncertainty_interval[1]:.4g}]" if g.uncertainty else "none",
             g.low, g.high] for g in ident.prognoses]
    return _table(["quantity", "unit", "candidates predict: min", "candidates predict: max",
                   "its model uncertainty interval (prediction − true)", "true value: low", "true value: high"],
                  rows, left=2) + (
        "<p class='notes'>Prognosis range: [min q − b, max q − a] with [a, b] the central interval of the "
        "quantity's model uncertainty (true value = prediction − model error, as in Eq. 4).</p>")


def _thresholds(ident) -> str:
    table = ident.thresholds_table()
    suspects = set(ident.leave_one_out.suspects)
    # The headers are thresholds.csv's column names, so the report and the file read alike.
    rows = [[v if not isinstance(v, float) or col not in COUNTS else int(v) for col, v in zip(table.columns, row)]
            for row in table.itertuples(index=False)]
    html = _table(list(table.columns), rows, left=2, row_class=lambda k: "suspect" if k in suspects else "")
    html += ("<p class='notes'>measured = y; uc_mean, uc_sd: mean and standard deviation of the combined "
             "uncertainty U<sub>c</sub>; threshold_low, threshold_high: the bounds on the residual g(θ) − y "
             "(Eqs. 5-6); the same columns as thresholds.csv."
             + (" The counts leave out the invalid instances (NaN predictions)." if ident.falsification.n_invalid
                else "") + "</p>")
    if ident.sensor_mapping is not None:
        html += f"<p>Model outputs matched to the sensors {escape(ident.mapping_text())}.</p>"
    excluded = ident.project.excluded
    if excluded:
        html += f"<p>Excluded from the identification: {escape(', '.join(s.name for s in excluded))}.</p>"
    return html


COUNTS = ("falsified", "falsified_only_by", "candidates_without_sensor")


def _sources(ident) -> str:
    names = ident.project.sensor_names
    rows = [[src.name, src.kind, src.describe(),
             "all" if len(src.sensors) == len(names) else ", ".join(names[j] for j in src.sensors)]
            for src in ident.project.uncertainty]
    return _table(["source", "kind", "distribution", "sensors"], rows, left=4) + (
        "<p class='notes'>U<sub>c</sub> = Σ model sources − Σ measurement sources at each sensor (Eq. 4); "
        "a source adds nothing at the sensors it does not cover.</p>")


def _settings(ident) -> str:
    p, t = ident.project, ident.thresholds
    sampling = p.sampling.describe() if p.sampling else f"precomputed instances ({p.model.predictions.name})"
    kinds = {"exact": "exact (every source normal, or one source)",
             "convolution": "numerical convolution of the sources (error < 1e-4 of the width)",
             "monte_carlo": f"Monte Carlo, {p.n_samples:,} samples (seed {p.seed})"}
    methods = ident.bound_methods()
    combined = kinds[next(iter(methods))] if len(methods) == 1 else "; ".join(
        f"{kinds[kind]} at {', '.join(names)}" for kind, names in methods.items())
    model = p.model.function or (f"command {' '.join(p.model.command.command)}" if p.model.command
                                 else p.model.predictions.name)
    rows = [["model", model], ["instances", sampling], ["target probability φ", f"{p.phi:g}"],
            ["correction", f"{p.correction} (per-sensor probability {t.probability:.6f})"],
            ["combined uncertainty", combined], ["guarantee", t.guarantee()],
            ["borderline instances (verdict changes within 2 Monte Carlo SE)", f"{ident.borderline:,}"],
            ["run time", f"{ident.elapsed:.1f} s"]]
    return _table(["setting", "value"], rows, left=2)


def _figure(figures: dict[str, bytes], name: str, caption: str) -> str:
    data = base64.b64encode(figures[name]).decode("ascii")
    return (f"<figure><img alt='{escape(name)}' src='data:image/png;base64,{data}'>"
            f"<figcaption>{escape(caption)}</figcaption></figure>")


def _notes() -> str:
    return """<h2>Definitions</h2><div class='notes'>
<p><b>Falsification</b> (Eq. 8): an instance is a candidate iff T<sub>low,i</sub> ≤ g<sub>i</sub>(θ) − y<sub>i</sub>
≤ T<sub>high,i</sub> at every sensor; the bounds are the shortest intervals of U<sub>c,i</sub> holding the
per-sensor probability (Eq. 5).</p>
<p><b>Invalid instances</b>: an instance whose predictions hold NaN (a diverged model, or a failed run of an
external program) cannot be compared with the measurements: it is neither a candidate nor falsified, and it is
left out of the per-sensor counts, the leave-one-out counts and the sensitivity curves.</p>
<p><b>Leave one sensor out</b>: candidates without sensor i = candidates + instances falsified by sensor i and no
other. When there is no candidate but ignoring one sensor leaves some, that sensor alone falsifies the model class.</p>
<p><b>Scale factor s</b>: thresholds scaled about their centre c = (T<sub>low</sub> + T<sub>high</sub>)/2,
T(s) = c + s (T − c): the spread of every uncertainty scaled by s, the systematic bias kept. An instance is a
candidate for s ≥ max<sub>i</sub> |r<sub>i</sub> − c<sub>i</sub>| / h<sub>i</sub>, h = (T<sub>high</sub> − T<sub>low</sub>)/2.</p>
<p><b>φ</b>: thresholds widen with φ, so each instance is a candidate for every φ at or above its own φ<sub>min</sub>:
exact for a normal U<sub>c</sub> (from its ppf, Eq. 6), counted on a grid of φ for Monte Carlo U<sub>c</sub>.</p>
</div>"""
