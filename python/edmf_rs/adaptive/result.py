"""What an adaptive EDMF run found and how: the candidates (decided by Eq. 8
on real model outputs) and a record of every wave."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..engine.result import FalsificationResult
from ..engine.sampling import Parameter


@dataclass(frozen=True, eq=False)
class WaveRecord:
    """One wave of real model runs and the emulator fitted after it.

    Attributes
    ----------
    index, kind
        Wave number and how its runs were placed: ``"initial"`` (Sobol'
        design over the domain), ``"adaptive"`` (spread over the kept region),
        ``"fallback"`` (over the whole domain, because the previous emulator
        failed validation) or ``"final"`` (spread over the kept region; no
        emulator is fitted after it).
    n_runs, n_runs_total
        Real runs spent in this wave, and in all waves up to it.
    n_candidates
        Real runs so far that pass Eq. 8.
    kept_fraction
        Share of the screening sample the emulator keeps (its volume share of
        the unit parameter cube); ``mean_kept_fraction`` the same with c = 0.
    validated, loo_error, loo_coverage
        Emulator validation: leave-one-out RMS error per sensor over its
        threshold width, share of runs within c leave-one-out deviations.
    sigma_ratio
        95th percentile over kept points of sigma_i / threshold width,
        largest over sensors. When none is kept: over the points the next
        wave is drawn from, those of the checked points (below) that need the
        smallest margin c.
    min_required_c
        Smallest margin c (in emulator standard deviations) that would keep a
        screening point. When none is kept, the smallest over the checked
        points: the screening rejects most points on an upper bound of sigma
        without computing it, so the emulator's exact sigma is computed at a
        few thousand points only, those whose emulated mean is nearest to
        passing and the first 4096 of the sample (a Sobol' net over it); with
        up to 4096 screening points, every one.
    kept_sample
        Up to a few hundred kept points (parameter units), for plots.
    problems
        Emulator warnings (constant outputs, fit failures) in words.
    components
        Principal components emulated (``basis = "pca"``), None with one
        emulator per sensor.
    fit_seconds
        Wall time of the emulator fit (and its hyperparameter search).
    
    Examples
    --------
    ``adaptive_falsify``'s example runs the waves; each is one of these:

    >>> import dataclasses
    >>> [f.name for f in dataclasses.fields(WaveRecord)][:3]
    ['index', 'kind', 'n_runs']
    """

    index: int
    kind: str
    n_runs: int
    n_runs_total: int
    n_candidates: int
    kept_fraction: float | None = None
    mean_kept_fraction: float | None = None
    validated: bool | None = None
    loo_error: np.ndarray | None = None
    loo_coverage: np.ndarray | None = None
    sigma_ratio: float | None = None
    min_required_c: float | None = None
    kept_sample: np.ndarray | None = None
    problems: tuple[str, ...] = ()
    components: int | None = None
    fit_seconds: float | None = None

    @property
    def fallback(self) -> bool:
        return self.kind == "fallback"

    def as_dict(self) -> dict:
        out = {"index": self.index, "kind": self.kind, "runs": self.n_runs, "runs_total": self.n_runs_total,
               "candidates_so_far": self.n_candidates, "fallback": self.fallback,
               "kept_fraction": self.kept_fraction, "mean_kept_fraction": self.mean_kept_fraction,
               "validated": self.validated, "sigma_ratio": self.sigma_ratio, "min_required_c": self.min_required_c,
               "problems": list(self.problems), "components": self.components, "fit_seconds": self.fit_seconds}
        for key in ("loo_error", "loo_coverage"):
            value = getattr(self, key)
            out[key] = None if value is None else [float(v) for v in value]
        return out


@dataclass(frozen=True, eq=False)
class AdaptiveResult:
    """The outcome of :func:`edmf_rs.adaptive_falsify`.

    Attributes
    ----------
    parameters : tuple of Parameter
        The parameter domains.
    falsification : FalsificationResult
        Eq. 8 over every real run; its candidates are the candidate model set.
    waves : tuple of WaveRecord
        Each wave: runs spent, kept share, emulator validation.
    run_parameters, run_predictions : numpy.ndarray
        Every real run, in the order run; ``run_wave`` says which wave.
    stop_reason : str
        Why the waves stopped (converged, budget, ...).
    n_screen, c : int, float
        Screening sample size and the emulator margin in standard deviations.
    basis : str
        The emulators used: ``"sensors"`` (a Gaussian process per sensor) or
        ``"pca"`` (Gaussian processes on principal components of the outputs;
        ``components`` of each wave says how many).

    Examples
    --------
    ``adaptive_falsify``'s example returns one; its candidates are those of
    ``falsification``, Eq. 8 over every real run:

    >>> import dataclasses
    >>> [f.name for f in dataclasses.fields(AdaptiveResult)][:3]
    ['parameters', 'falsification', 'waves']
    """

    parameters: tuple[Parameter, ...]
    falsification: FalsificationResult
    waves: tuple[WaveRecord, ...]
    run_parameters: np.ndarray
    run_predictions: np.ndarray
    run_wave: np.ndarray
    stop_reason: str
    n_screen: int
    c: float
    basis: str = "sensors"

    def emulator_description(self) -> str:
        """The emulators in words, e.g. "one Gaussian process per sensor"."""
        n_m = int(self.run_predictions.shape[1])
        if self.basis != "pca":
            return "one Gaussian process per sensor"
        k = sorted({w.components for w in self.waves if w.components is not None})
        count = "" if not k else (f"{k[0]}" if len(k) == 1 else f"{k[0]} to {k[-1]}")
        count += " " if count else ""
        return (f"Gaussian processes on the {count}leading principal components of the standardised outputs of the "
                f"{n_m} sensors, their variance propagated back to every sensor")

    @property
    def n_runs(self) -> int:
        return int(self.run_parameters.shape[0])

    @property
    def n_candidates(self) -> int:
        return self.falsification.n_candidates

    @property
    def model_class_falsified(self) -> bool:
        return self.falsification.model_class_falsified

    @property
    def candidate_parameters(self) -> np.ndarray:
        return self.falsification.candidate_parameters

    @property
    def candidate_predictions(self) -> np.ndarray:
        return self.falsification.candidate_predictions

    def parameter_ranges(self) -> dict[str, tuple[float, float] | None]:
        """Each parameter's [min, max] over the candidates (None without candidates)."""
        theta = self.candidate_parameters
        return {p.name: (float(theta[:, j].min()), float(theta[:, j].max())) if theta.shape[0] else None
                for j, p in enumerate(self.parameters)}

    @property
    def confidence(self) -> str | None:
        """When no candidate is found: how sure that is (runs spent, emulator uncertainty left)."""
        if not self.model_class_falsified:
            return None
        fitted = [w for w in self.waves if w.kept_fraction is not None]
        last = fitted[-1] if fitted else None
        text = (f"No candidate model: none of {self.n_runs} real model runs passes Eq. 8 "
                f"({len(self.waves)} waves; stopped: {self.stop_reason}).")
        if last is None:
            return text
        valid = "passed" if last.validated else "FAILED"
        text += (f" The last emulator (leave-one-out validation {valid}, worst coverage "
                 f"{float(np.min(last.loo_coverage)):.2f}, worst RMS error {float(np.max(last.loo_error)):.3g} "
                 f"threshold widths) keeps {last.kept_fraction:.3g} of {self.n_screen:,} screening points with a "
                 f"margin of c = {self.c:g} standard deviations")
        if last.min_required_c is not None and np.isfinite(last.min_required_c):
            text += (f"; the most nearly consistent point would need c = {last.min_required_c:.3g}, with sigma up to "
                     f"{last.sigma_ratio:.3g} threshold widths there")
        return text + "."

    def summary(self) -> str:
        lines = [f"adaptive EDMF: {self.n_runs} real model runs in {len(self.waves)} waves "
                 f"(stopped: {self.stop_reason}), {self.n_candidates} candidates"]
        for w in self.waves:
            kept = "" if w.kept_fraction is None else f", kept {w.kept_fraction:.3g} of the domain"
            valid = "" if w.validated is None else (", emulator validated" if w.validated else
                                                     ", emulator FAILED validation")
            lines.append(f"  wave {w.index} ({w.kind}): {w.n_runs} runs{kept}{valid}")
        for name, span in self.parameter_ranges().items():
            if span is not None:
                lines.append(f"  {name}: {span[0]:.6g} .. {span[1]:.6g}")
        if self.confidence:
            lines.append(self.confidence)
        return "\n".join(lines)

    def as_dict(self) -> dict:
        """The adaptive part of summary.json."""
        return {"method": "adaptive", "runs": self.n_runs, "stop_reason": self.stop_reason,
                "n_screen": self.n_screen, "c": self.c, "waves": [w.as_dict() for w in self.waves],
                "confidence": self.confidence}

    def __repr__(self) -> str:
        return (f"AdaptiveResult(n_runs={self.n_runs}, waves={len(self.waves)}, n_candidates={self.n_candidates}, "
                f"stop_reason={self.stop_reason!r})")
