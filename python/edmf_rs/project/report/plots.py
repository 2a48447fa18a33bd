"""The figures of an identification, as PNG bytes (matplotlib, no pyplot state).

Falsified instances are not kept by the falsification, so they are drawn from
the run's deterministic sample of every k-th instance; candidates are drawn
all, or, when there are many, the candidate set's bounded sample (bottom-k of
the hashed instance index, see :mod:`edmf_rs.project.candidates`).
"""

from __future__ import annotations

import io
from collections import Counter

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import Formatter, MaxNLocator, NullFormatter


CANDIDATE = "#1f6fb4"
FALSIFIED = "#b0b0b0"
ALERT = "#c0392b"
MAX_CANDIDATES = 2000


def figures(ident) -> dict[str, bytes]:
    """Every figure of the report, by file stem."""
    return {
        "leave_one_out": _png(leave_one_out(ident)),
        "residuals": _png(residuals(ident)),
        "scatter_matrix": _png(scatter_matrix(ident)),
        "parallel_coordinates": _png(parallel_coordinates(ident)),
        "sensitivity": _png(sensitivity(ident)),
    }


def _png(fig: Figure) -> bytes:
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": None})
    return buf.getvalue()


def _evenly(n: int, limit: int) -> np.ndarray:
    """Up to ``limit`` evenly spaced indices of n rows (deterministic)."""
    return np.arange(n) if n <= limit else np.unique(np.linspace(0, n - 1, limit).round().astype(int))


def _candidates(ident) -> tuple[np.ndarray, np.ndarray]:
    """Parameters and predictions of the candidates drawn: the candidate set's bounded sample
    (all of them when there are at most ``candidates.SAMPLE``), never every candidate."""
    c = ident.candidate_set
    keep = _evenly(c.sample_index.size, MAX_CANDIDATES)
    return c.sample_parameters[keep], c.sample_predictions[keep]


def _falsified(ident) -> tuple[np.ndarray, np.ndarray]:
    s = ident.sample
    return s.parameters[~s.is_candidate], s.predictions[~s.is_candidate]


def plain(text: str) -> str:
    """Text shown as written: a ``$`` in a name must not start matplotlib's mathtext."""
    return str(text).replace("$", r"\$")


def short(v: float, _pos=None, digits: int = 3) -> str:
    """A tick label of at most a few characters: 20000 -> '2e4', 0.5 -> '0.5'.

    Examples
    --------
    >>> short(35000.0), short(0.25), short(-1.5e-6), short(293.15, digits=5)
    ('3.5e4', '0.25', '-1.5e-6', '293.15')
    """
    text = f"{v:.{digits}g}"
    if "e" in text:
        mantissa, exponent = text.split("e")
        text = f"{mantissa}e{int(exponent)}"
    return text


class DistinctShort(Formatter):
    """`short` tick labels with as few significant digits as keep the ticks apart
    (3 at least): 293.0 .. 293.45 reads 293, 293.15, 293.3, 293.45, not 293 four times."""

    digits = 3

    def set_locs(self, locs):
        super().set_locs(locs)
        values = sorted(set(float(v) for v in locs))
        self.digits = 3
        while self.digits < 17 and len({short(v, digits=self.digits) for v in values}) < len(values):
            self.digits += 1

    def __call__(self, x, pos=None):
        return short(x, digits=self.digits)


def cut(name, limit: int = 24) -> str:
    """``name`` in at most ``limit`` characters: a longer one keeps its start and end around an ellipsis.

    Examples
    --------
    >>> cut("deflection_at_midspan_north_girder_2", 16)
    'deflecti…irder_2'
    """
    name = str(name)
    if len(name) <= limit:
        return name
    head = limit // 2
    return name[:head] + "…" + name[len(name) - (limit - 1 - head):]


def short_names(names, limit: int = 24) -> list[str]:
    """Names for a figure (the report's tables keep them whole): each `cut` to
    ``limit`` characters, and numbered by position (#k) where cut ones coincide."""
    out = [cut(n, limit) for n in names]
    count = Counter(out)
    return [f"{text} #{k + 1}" if count[text] > 1 else text for k, text in enumerate(out)]


def _sensor_labels(ax, names, axis="x") -> None:
    names = [plain(n) for n in short_names(names)]
    ticks = np.arange(len(names))
    slot = (ax.figure.get_figwidth() - 2.0) / max(len(names), 1)  # inches per sensor, roughly
    rotation = 60 if len(names) > 8 or 0.075 * max(map(len, names)) > 0.9 * slot else 0
    if axis == "x":
        ax.set_xticks(ticks, names, rotation=rotation, ha="right" if rotation else "center", fontsize=8,
                      rotation_mode="anchor" if rotation else "default")
        ax.set_xlim(-0.6, len(names) - 0.4)


def _note(ax, text: str) -> None:
    """A sentence in the middle of a panel, in place of a curve that would say less (over any line)."""
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, fontsize=10, color=ALERT,
            bbox={"facecolor": "white", "edgecolor": "none"}, zorder=5)


def _counts_axis(ax, counts, note: str) -> bool:
    """An axis of counts from 0, integer ticks, a little room above the largest; when
    every count is 0, the ``note`` instead of a flat line on a meaningless scale (False)."""
    counts = np.asarray(counts, dtype=np.float64)
    if not (counts > 0).any():
        _note(ax, note)
        ax.set_yticks([])
        ax.set_ylim(0, 1)
        return False
    ax.set_ylim(0, 1.3 * float(counts.max()))  # room for a legend
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    return True


def leave_one_out(ident) -> Figure:
    loo = ident.leave_one_out
    n = len(loo.sensors)
    fig = Figure(figsize=(max(6.0, 0.55 * n + 2), 5.2), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    x = np.arange(n)
    colours = [ALERT if i in loo.suspects else CANDIDATE for i in range(n)]
    top.bar(x, loo.candidates_without_sensor, color=colours)
    top.set_ylabel("candidates without\nthis sensor")
    top.set_title("Leave one sensor out (red: this sensor alone falsifies the model class)", fontsize=10)
    if _counts_axis(top, loo.candidates_without_sensor, "No candidate, with every sensor or without any one"):
        top.axhline(loo.n_candidates, color="k", ls="--", lw=1, label=f"all sensors: {loo.n_candidates:,}")
        top.legend(loc="upper right", fontsize=8)
    valid = loo.n_instances - loo.n_invalid  # invalid instances (NaN) are neither candidates nor falsified
    share = 100.0 * loo.per_sensor_falsified / max(valid, 1)
    bottom.bar(x, share, color=FALSIFIED, label="falsified by this sensor")
    bottom.bar(x, 100.0 * loo.falsified_only_by / max(valid, 1), color="#555555", label="... and by no other")
    bottom.set_ylabel("% of valid instances" if loo.n_invalid else "% of instances")
    if (share > 0).any():
        bottom.set_ylim(0, min(105.0, 1.15 * float(share.max())))
        bottom.legend(loc="upper right", fontsize=8)
    else:
        _note(bottom, "No valid instance: every one has NaN predictions" if loo.n_instances and not valid
              else "No instance is falsified by any sensor")
        bottom.set_ylim(0, 100)
    _sensor_labels(bottom, loo.sensors)
    return fig


def residuals(ident) -> Figure:
    """Residuals g - y scaled to the thresholds: (r - c) / h, so each sensor's thresholds are at -1 and +1."""
    t, y = ident.thresholds, ident.falsification.measurements
    c, h = 0.5 * (t.low + t.high), 0.5 * (t.high - t.low)
    names = ident.project.sensor_names
    n = len(names)
    fig = Figure(figsize=(max(6.0, 0.55 * n + 2), 4.5), layout="constrained")
    ax = fig.subplots()
    ax.axhspan(-1, 1, color="#d9ead3", label="threshold bounds")
    rng = np.random.default_rng(0)  # jitter only; fixed for reproducible figures
    _, false_pred = _falsified(ident)
    if false_pred.shape[0]:
        z = (false_pred - y - c) / h
        xs = np.arange(n) + rng.uniform(-0.25, 0.25, z.shape)
        ax.plot(xs.ravel(), z.ravel(), ".", ms=2, color=FALSIFIED, label="falsified (sample)")
    _, cand_pred = _candidates(ident)
    if cand_pred.shape[0]:
        z = (cand_pred - y - c) / h
        xs = np.arange(n) + rng.uniform(-0.15, 0.15, z.shape)
        ax.plot(xs.ravel(), z.ravel(), ".", ms=3, color=CANDIDATE, label="candidates")
    elif ident.sensitivity.closest_predictions is not None:
        z = (ident.sensitivity.closest_predictions - y - c) / h
        ax.plot(np.arange(n), z, "o-", color=ALERT, ms=5, label="closest instance")
    if max(abs(v) for v in ax.get_ylim()) > 8.0:
        ax.set_yscale("symlog", linthresh=2.0)  # far-off falsified instances stay visible
    ax.set_ylabel("(g - y - c) / h   (thresholds at ±1)")
    ax.set_title("Residuals against the threshold bounds, per sensor", fontsize=10)
    fig.legend(loc="outside right upper", fontsize=8)
    _sensor_labels(ax, names)
    return fig


def _axis(ax, param, which: str) -> None:
    """One parameter's axis: its domain, at most 4 short tick labels (x ones
    turned 45 degrees), so labels never run into each other."""
    getattr(ax, f"set_{which}label")(plain(_label(param)), fontsize=9)
    getattr(ax, f"set_{which}scale")("log" if param.scale == "log" else "linear")
    getattr(ax, f"set_{which}lim")(param.low, param.high)
    axis = getattr(ax, f"{which}axis")
    if param.scale == "linear" or param.high < 10.0 * param.low:  # less than a decade: no log ticks in it
        axis.set_major_locator(MaxNLocator(4))
        axis.set_major_formatter(DistinctShort())
    axis.set_minor_formatter(NullFormatter())
    ax.tick_params(axis=which, labelsize=7)
    if which == "x":
        for tick in ax.get_xticklabels():
            tick.set_rotation(45)
            tick.set_horizontalalignment("right")
            tick.set_rotation_mode("anchor")
        ax.tick_params(axis="x", labelrotation=45)


def _label(param, log: bool = False) -> str:
    """A parameter's axis label: its name and unit, `cut` to fit a panel."""
    unit = f" [{cut(param.unit, 10)}]" if param.unit else ""
    return f"{cut(param.name, 28 - len(unit))}{unit}" + (" (log)" if log and param.scale == "log" else "")


def _bins(values: np.ndarray, param, *others: np.ndarray) -> np.ndarray:
    """Histogram edges: one bin per value of a grid (no empty bins between grid values), else 30.

    The outer edges hold the domain and every value (of ``others`` too):
    edges mapped back from [0, 1] may miss an end value by a rounding error
    (exp(log(1e-3)) > 1e-3), and a value outside the bins is not counted.
    """
    unique = np.unique(values)
    if 1 < unique.size <= 120:
        x = param.to_unit(unique)
        unit = np.concatenate([[x[0] - (x[1] - x[0]) / 2], (x[1:] + x[:-1]) / 2, [x[-1] + (x[-1] - x[-2]) / 2]])
        edges = param.from_unit(np.clip(unit, 0.0, 1.0))
    else:
        edges = param.from_unit(np.linspace(0.0, 1.0, 31))
    shown = [np.asarray(v, dtype=np.float64).ravel() for v in (values, *others) if np.size(v)]
    edges[0] = min(edges[0], param.low, *(v.min() for v in shown))
    edges[-1] = max(edges[-1], param.high, *(v.max() for v in shown))
    return edges


def scatter_matrix(ident) -> Figure:
    """Candidates over falsified instances, for every pair of parameters (lower triangle)."""
    params = ident.project.parameters
    p = len(params)
    size = max(4.5, 2.4 * p)
    fig = Figure(figsize=(size, size * (0.75 if p == 1 else 1.0)), layout="constrained")
    axes = np.atleast_2d(fig.subplots(p, p, squeeze=False))
    cand, _ = _candidates(ident)
    false_theta, _ = _falsified(ident)
    closest = ident.sensitivity.closest_parameters if ident.falsification.n_candidates == 0 else None
    for i in range(p):
        for j in range(p):
            ax = axes[i, j]
            if j > i:
                ax.set_visible(False)
                continue
            if i == j:
                param = params[i]
                bins = _bins(ident.sample.parameters[:, i], param, cand[:, i])
                ax.hist(ident.sample.parameters[:, i], bins=bins, color=FALSIFIED, label="instances (sample)")
                if cand.shape[0]:
                    ax.hist(cand[:, i], bins=bins, color=CANDIDATE, label="candidates")
                if closest is not None:
                    ax.axvline(closest[i], color=ALERT, label="closest instance")
                _axis(ax, param, "x")
                ax.set_yticks([])
                if i == 0:
                    ax.legend(fontsize=7, loc="upper right")
                continue
            if false_theta.shape[0]:
                ax.plot(false_theta[:, j], false_theta[:, i], ".", ms=2, color=FALSIFIED)
            if cand.shape[0]:
                ax.plot(cand[:, j], cand[:, i], ".", ms=3, color=CANDIDATE)
            if closest is not None:
                ax.plot(closest[j], closest[i], "*", ms=12, color=ALERT)
            _axis(ax, params[j], "x")
            _axis(ax, params[i], "y")
    fig.suptitle("Candidate model set (blue) over falsified instances (grey)", fontsize=10)
    return fig


def parallel_coordinates(ident) -> Figure:
    """Each candidate as a line across the parameters, each axis its domain (0: low, 1: high)."""
    params = ident.project.parameters
    p = len(params)
    fig = Figure(figsize=(max(5.0, 1.8 * p + 2), 4.0), layout="constrained")
    ax = fig.subplots()
    x = np.arange(p)
    style = "-" if p > 1 else "o"

    def unit(theta):
        return np.column_stack([param.to_unit(theta[:, j]) for j, param in enumerate(params)])

    false_theta, _ = _falsified(ident)
    if false_theta.shape[0]:
        ax.plot(x, unit(false_theta[_evenly(false_theta.shape[0], 300)]).T, style, color=FALSIFIED,
                lw=0.5, alpha=0.5)
    cand, _ = _candidates(ident)
    if cand.shape[0]:
        ax.plot(x, unit(cand).T, style, color=CANDIDATE, lw=0.7, alpha=0.35)
    elif ident.sensitivity.closest_parameters is not None:
        ax.plot(x, unit(ident.sensitivity.closest_parameters[None, :]).T, style + ("" if p == 1 else "o"),
                color=ALERT, lw=2, label="closest instance")
        ax.legend(fontsize=8)
    for k, param in enumerate(params):
        ax.axvline(k, color="k", lw=0.8)
        formatter = DistinctShort()
        formatter.set_locs([param.low, param.high])  # 1000 and 1000.4, not 1e3 twice
        high, low = formatter(param.high), formatter(param.low)
        ax.annotate(high, (k, 1.0), xytext=(3, 2), textcoords="offset points", fontsize=7)
        ax.annotate(low, (k, 0.0), xytext=(3, -9), textcoords="offset points", fontsize=7)
    labels = [plain(_label(q, log=True)) for q in params]
    ax.set_xticks(x, labels, fontsize=9)
    ax.set_xlim(-0.3, p - 0.7 if p > 1 else 0.3)
    ax.set_ylim(-0.08, 1.08)
    ax.set_ylabel("position in the domain")
    ax.set_title("Parallel coordinates: candidates (blue), falsified sample (grey)", fontsize=10)
    return fig


def sensitivity(ident) -> Figure:
    s, phi = ident.sensitivity, ident.thresholds.phi
    fig = Figure(figsize=(10.0, 3.8), layout="constrained")
    left, right = fig.subplots(1, 2)
    left.axvline(1.0, color="k", ls="--", lw=1, label="s = 1 (as specified)")
    if np.isfinite(s.smallest_scale) and s.scales[0] <= s.smallest_scale <= s.scales[-1]:
        left.axvline(s.smallest_scale, color=ALERT, ls=":", lw=1.2, label=f"first candidate: s = {s.smallest_scale:.3g}")
    left.set_xscale("log")
    if s.candidates_at_scale.any():
        left.plot(s.scales, s.candidates_at_scale, color=CANDIDATE)
        left.set_yscale("symlog", linthresh=1.0)  # counts from 0 to N: small sets stay visible
        left.set_ylim(0, 1.15 * float(s.candidates_at_scale.max()))
        left.set_ylabel("candidate models")
    else:  # as on the right: a sentence, not an all-zero curve on a fractional axis
        _note(left, f"No instance is a candidate at any scale\nfrom {s.scales[0]:.3g} to {s.scales[-1]:.3g}")
        left.set_yticks([])
        left.set_xlim(s.scales[0], s.scales[-1])
    left.set_xlabel("scale factor s on the spread of every uncertainty")
    left.legend(fontsize=8)
    left.set_title("Candidates against the size of the uncertainties", fontsize=10)
    right.axvline(phi, color="k", ls="--", lw=1, label=f"phi = {phi:g}")
    right.set_xlabel("target identification probability phi" + ("" if s.phi_exact else " (Monte Carlo grid)"))
    right.set_title("Candidates against phi", fontsize=10)
    if s.phis.size and np.any(s.candidates_at_phi > 0):
        right.plot(s.phis, s.candidates_at_phi, "-" if s.phi_exact else ".-", color=CANDIDATE)
        _counts_axis(right, s.candidates_at_phi, "")
        right.set_ylabel("candidate models")
    else:  # an all-zero curve on a meaningless axis says less than one sentence
        top = f"{s.phis.max():.6g}" if s.phis.size else "1"
        _note(right, f"No instance is a candidate\nat any phi up to {top}")
        right.set_yticks([])
        right.set_xlim(min(0.0, phi), 1.0)
    right.legend(fontsize=8)
    return fig
