"""Figures of Goulet & Smith (2013): Fig. 3 and Figs. 6-8.

Figures are built with ``matplotlib.figure.Figure`` directly (no pyplot), so
they work under any backend, Agg included, and leave no global state. Each
function returns the Figure and, given ``path``, also saves it as a PNG
(atomically: a temporary file in the same folder, then ``os.replace``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle
from matplotlib.transforms import blended_transform_factory

from ..stream.atomic import atomic_path
from . import cantilever as cl

PANEL_LETTERS = "abcdefgh"
GPA = 1e3  # the E axis is in 10^3 MPa (GPa), as in the paper


def save_figure(fig: Figure, path, dpi: int = 150) -> Path:
    """Save ``fig`` as a PNG at ``path`` atomically.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or pathlib.Path
    dpi : int, default 150

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    OSError
        If the file cannot be written.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from matplotlib.figure import Figure
    >>> from edmf_rs.paper import figures
    >>> path = figures.save_figure(Figure(), pathlib.Path(tempfile.mkdtemp()) / "empty.png")
    >>> path.read_bytes()[1:4] == b"PNG"
    True
    """
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    return path


def close(fig: Figure) -> None:
    """Release a figure's memory (figures made here are not tracked by pyplot)."""
    fig.clear()


def _ellipse(bound: float, rho: float, n: int = 400) -> np.ndarray:
    """Points of D_M^2 = bound (Eq. 9) for unit variances and correlation rho."""
    t = np.linspace(0.0, 2.0 * np.pi, n)
    chol = np.linalg.cholesky(np.array([[1.0, rho], [rho, 1.0]]))
    return (np.sqrt(bound) * np.stack([np.cos(t), np.sin(t)])).T @ chol.T


def coverage_figure(results, path=None) -> Figure:
    """Fig. 3: draws, the ellipse of the assumed correlation and the Sidak rectangle.

    Parameters
    ----------
    results : iterable of CoverageResult
        One panel each, e.g. from `coverage.figure3_cases`.
    path : str or pathlib.Path, optional
        Where to save the PNG.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from edmf_rs.paper import coverage, figures
    >>> fig = figures.coverage_figure(coverage.figure3_cases(n_draws=100))
    >>> len(fig.axes)
    3
    """
    results = list(results)
    fig = Figure(figsize=(4.0 * len(results), 4.9), layout="constrained")
    axes = fig.subplots(1, len(results), sharex=True, sharey=True, squeeze=False)[0]
    for k, (ax, r) in enumerate(zip(axes, results)):
        ax.scatter(r.draws[:, 0], r.draws[:, 1], s=3, color="0.35", alpha=0.6, linewidths=0,
                   label="Realisations of X")
        e = _ellipse(r.chi2_bound, r.rho_assumed)
        ax.plot(e[:, 0], e[:, 1], "-", color="tab:blue", lw=1.6,
                label=f"Mahalanobis bound (assumed ρ = {r.rho_assumed:g})")
        t = r.thresholds
        ax.add_patch(Rectangle((t.low[0], t.low[1]), t.width[0], t.width[1], fill=False,
                               ls="--", lw=1.6, color="tab:red", label="Šidák threshold bounds"))
        ax.set_title(f"{PANEL_LETTERS[k]}) true ρ = {r.rho_true:g}")
        ax.text(0.03, 0.97, f"$P_M$ = {r.P_M:.2f}\n$P_T$ = {r.P_T:.2f}", transform=ax.transAxes,
                va="top", ha="left", fontsize=9,
                bbox={"boxstyle": "round", "fc": "white", "ec": "0.7", "alpha": 0.9})
        ax.set_xlabel("$x_1$")
        ax.set_aspect("equal")
        ax.set_xlim(-4.5, 4.5)
        ax.set_ylim(-4.5, 4.5)
        ax.grid(True, lw=0.3, alpha=0.5)
    axes[0].set_ylabel("$x_2$")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, frameon=False, markerscale=4)
    fig.suptitle("Fig. 3: draws inside the ellipse ($P_M$, Eq. 10) and the rectangle ($P_T$, Eq. 11)")
    if path is not None:
        save_figure(fig, path)
    return fig


_FIG_NUMBER = {1: 6, 2: 7, 3: 8}


def identification_figure(identifications, path=None, *, parameters=cl.E_GRID,
                          true_value: float = cl.E_TRUE) -> Figure:
    """Figs. 6-8: one panel per n_m with the Bayesian posterior (bars), the
    least-squares optimum, the candidate model set (shaded) and E* (star).

    Parameters
    ----------
    identifications : iterable of Identification
        Of one scenario, e.g. from `reproduce.example_identifications`.
    path : str or pathlib.Path, optional
        Where to save the PNG.
    parameters : array_like, default E_GRID
        The instances' Young's moduli, MPa.
    true_value : float, default E_TRUE
        E*, MPa.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from edmf_rs.examples import cantilever as cl
    >>> from edmf_rs.paper import figures, reproduce
    >>> fig = figures.identification_figure(reproduce.example_identifications(cl.scenario(2), n_sensors=(1, 10)))
    >>> len(fig.axes)
    2
    """
    idents = list(identifications)
    scn = idents[0].scenario
    e = np.asarray(parameters, dtype=np.float64) / GPA
    step = float(e[1] - e[0]) if e.size > 1 else 1.0
    ncols = 2 if len(idents) > 2 else len(idents)
    nrows = -(-len(idents) // ncols)
    fig = Figure(figsize=(5.2 * ncols, 3.3 * nrows + 0.8), layout="constrained")
    axes = fig.subplots(nrows, ncols, sharex=True, squeeze=False).ravel()
    for k, (ax, ident) in enumerate(zip(axes, idents)):
        top = 1.18 * max(float(ident.posterior.posterior.max()), 1e-12)
        cand = ident.falsification.candidate_indices
        if cand.size:
            ax.axvspan(e[cand[0]] - step / 2, e[cand[-1]] + step / 2, color="0.82", zorder=0, lw=0)
        else:
            ax.text(0.97, 0.93, "CMS empty:\nmodel class falsified", transform=ax.transAxes,
                    ha="right", va="top", fontsize=9, color="tab:red")
        ax.bar(e, ident.posterior.posterior, width=step, color="tab:blue", alpha=0.75,
               edgecolor="tab:blue", lw=0.3, zorder=2)
        on_axis = blended_transform_factory(ax.transData, ax.transAxes)
        ax.plot([e[ident.least_squares.index]], [0.16], marker="v", ms=10, color="black",
                ls="none", transform=on_axis, zorder=4, clip_on=False)
        ax.plot([true_value / GPA], [0.06], marker="*", ms=14, color="gold", mec="black",
                ls="none", transform=on_axis, zorder=5, clip_on=False)
        ax.set_ylim(0.0, top)
        ax.set_xlim(e[0] - step / 2, e[-1] + step / 2)
        ax.set_title(f"{PANEL_LETTERS[k]}) $n_m$ = {ident.n_sensors}")
        ax.grid(True, axis="y", lw=0.3, alpha=0.5)
    for ax in axes[len(idents):]:
        ax.set_visible(False)
    for ax in axes[-ncols:]:
        ax.set_xlabel("Young's modulus E [$10^3$ MPa]")
    for ax in axes[::ncols]:
        ax.set_ylabel("Posterior probability")
    handles = [
        Patch(color="tab:blue", alpha=0.75, label="Bayesian posterior"),
        Line2D([], [], marker="v", ms=9, color="black", ls="none", label="Least-sq. optimal solution"),
        Line2D([], [], marker="*", ms=13, color="gold", mec="black", ls="none", label="True solution"),
        Patch(color="0.82", label="Candidate model set (CMS)"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncol=4, frameon=False)
    fig.suptitle(f"Fig. {_FIG_NUMBER.get(scn.number, '')}: scenario {scn.number}, {scn.name.lower()}")
    if path is not None:
        save_figure(fig, path)
    return fig
