"""The design project file: the identification's model, parameters and
uncertainty sources, plus a [design] table naming the candidate locations.

    [design]
    candidates = "candidates.csv"   # name, type, location, cost (opt.), load_case (opt.), unit (opt.)
    k = 10                          # most sensors
    budget = 20.0                   # optional, needs costs
    n_simulations = 1000
    tolerance = 0.0                 # optional: stop when the gain (bits) falls below it
    fixed = ["D10-LC1"]             # optional: sensors every design has
    max_per_type = { strain = 5 }   # optional: most sensors of a type
    predictions = "g.npy"           # optional: precomputed predictions instead of a model
    columns = "g-columns.txt"       # optional, .npy only: its column names

The model (``[model] function``) returns one column per candidate location:
a DataFrame whose columns are the candidate names, or an array in the order
of the candidates file. With ``predictions`` (N x L, a .npy memory map or a
CSV with a header of names; see :mod:`edmf_rs.design._precomputed`) no
model, parameters or sampling are read; the columns are matched to the
candidates by name and the candidates taken in the columns' order. Several
load cases are simply more candidate locations (one column each). [[uncertainty]] sources select locations by name or
type as they select sensors; ``relative_to = "measured"`` is relative to the
mean prediction at the location (nothing is measured yet). [measurements] is
not used. Widths of the bins are those of each location's threshold bounds
for k sensors (:func:`edmf_rs.design.interval_widths`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..engine.sampling import Sampling
from ..engine.uncertainty import CombinedUncertainty
from ..project.errors import call_user_code
from ..project.inputs import import_function
from ..project.identification import IdentificationTable, identification, load_toml
from ..project.schema import (
    ProjectError,
    Sensor,
    _model,
    _parameters,
    _sampling,
    _uncertainty,
)
from ..project.sources import combine_sources, resolve_sources
from . import _checks, _precomputed
from ._candidates import Candidate, read_candidates

TOP_LEVEL = ("identification", "parameters", "sampling", "model", "uncertainty", "design")


@dataclass(frozen=True)
class DesignProject(IdentificationTable):
    """A checked design project (see the module docstring)."""

    sampling: Sampling | None
    candidates: tuple[Candidate, ...]
    uncertainty: tuple
    model_function: object
    model_options: dict
    batch_size: int
    k: int
    budget: float | None
    tolerance: float | None
    n_simulations: int
    fixed: tuple[int, ...]
    max_per_type: dict | None = None
    predictions_file: Path | None = None
    inputs: tuple[Path, ...] = ()  # the files it reads (never overwritten by an output)
    model_ref: str = ""  # [model] function as written ("module:function"), for messages

    @property
    def costs(self) -> np.ndarray:
        return np.array([c.cost for c in self.candidates])

    def predictions(self) -> np.ndarray:
        """(N, L) predictions of every instance at every candidate, checked against the candidates
        (a read-only memory map, not copied, for a .npy predictions file)."""
        names = [c.name for c in self.candidates]
        if self.predictions_file is not None:
            return _precomputed.load_predictions(self.predictions_file, names, str(self.file))
        parts = []
        what = f"{self.file}: model.function = '{self.model_ref}'"
        parameters = [q.name for q in self.sampling.parameters]

        def describe(row) -> str:
            return ", ".join(f"{n}={v:g}" for n, v in zip(parameters, row))

        first = 0
        for batch, theta in enumerate(self.sampling.batches(self.batch_size)):
            last = first + theta.shape[0] - 1
            # As `edmf-rs run` calls it: an exception (or sys.exit) is the model's failure, named, exit 1.
            out = call_user_code(lambda t: self.model_function(t, **self.model_options), theta, what=what,
                                 where=f"batch {batch} (instances {first}..{last})", first=first, describe=describe)
            parts.append(_columns(out, names, theta.shape[0], self.file))
            first += theta.shape[0]
        g = np.concatenate(parts)
        bad = _checks.first_non_finite(g)
        if bad is not None:
            i, j = bad
            raise ProjectError(f"{self.file}: model.function: non-finite predictions at location "
                               f"'{names[j]}' (first: {g[i, j]} at instance {i}); expected finite predictions at "
                               "every candidate")
        return g

    def combined_uncertainty(self, predictions: np.ndarray) -> CombinedUncertainty:
        """U_c of every candidate (Eq. 4), named by the candidates; "measured" values are the mean predictions.

        Raises
        ------
        ProjectError
            A location whose every source is ``relative_to = "measured"``
            while its mean prediction is 0 (its U_c would be 0: thresholds of
            zero width), or sources that cannot be combined; the message names
            the file and the location.
        """
        mean = np.asarray(predictions.mean(axis=0), dtype=np.float64)
        names = [c.name for c in self.candidates]
        covering: list[list] = [[] for _ in names]
        for src in self.uncertainty:
            for j in src.sensors:
                covering[j].append(src)
        for j, sources in enumerate(covering):
            if sources and mean[j] == 0 and all(s.relative_to == "measured" for s in sources):
                listed = ", ".join(f"'{s.name}'" for s in sources)
                raise ProjectError(
                    f"{self.file}: uncertainty: location '{names[j]}' has only sources relative_to = \"measured\" "
                    f"({listed}), and in a design they are relative to the mean prediction at the location, which "
                    "is 0 there: its combined uncertainty would be zero (thresholds of zero width); give it a source "
                    "with an absolute value (relative_to = \"absolute\", e.g. the sensor's noise), or leave the "
                    "location out of the candidates")
        try:
            return combine_sources(self.uncertainty, mean, n_samples=self.n_samples, seed=self.seed,
                                   sensor_names=names)
        except ValueError as exc:
            relative = any(s.relative_to == "measured" for s in self.uncertainty)
            raise ProjectError(f"{self.file}: uncertainty: {exc}" + (
                " (in a design, relative_to = \"measured\" is relative to the mean prediction at each location)"
                if relative else "")) from None


def _columns(out, names: list[str], n: int, label) -> np.ndarray:
    """The model's output as (n, L) float64 in candidate order; errors name the locations."""
    columns = getattr(out, "columns", None)
    if columns is not None:
        got = [str(c) for c in columns]
        missing = [c for c in names if c not in got]
        extra = [c for c in got if c not in names]
        if missing or extra:
            raise ProjectError(
                f"{label}: the candidate locations and the model's columns disagree: "
                + (f"no model column for location(s) {', '.join(missing[:5])}" if missing else "")
                + ("; " if missing and extra else "")
                + (f"model column(s) {', '.join(extra[:5])} are not candidate locations" if extra else ""))
        out = out[names].to_numpy(dtype=np.float64)
    out = np.asarray(out, dtype=np.float64)
    if out.shape != (n, len(names)):
        raise ProjectError(f"{label}: the candidate locations and the model's columns disagree: the model returned "
                           f"shape {out.shape} for {n} parameter sets, expected ({n}, {len(names)}), one column "
                           f"per location ({', '.join(names[:3])}, ...)")
    return out


def read_design_project(path: str | Path) -> DesignProject:
    """Reads and checks a design project file; raises ProjectError naming the file and key."""
    path = Path(path)
    label = str(path)
    root = load_toml(path)
    root.check_keys(TOP_LEVEL)
    ident = identification(root, path, phi_ok=lambda phi: 0.0 < phi < 1.0, phi_what="a probability in (0, 1)")
    t = root.table("design")
    t.check_keys(("candidates", "k", "budget", "tolerance", "n_simulations", "fixed", "max_per_type", "predictions",
                  "columns"))
    candidates_file = path.parent / t.get("candidates", "str", what="a CSV file of candidate locations")
    candidates = read_candidates(candidates_file, label)
    predictions_file = t.get("predictions", "str", None, what="a .npy or .csv file of predictions")
    function = sampling = model = None
    if predictions_file is not None:
        predictions_file = path.parent / predictions_file
        names = _precomputed.column_names(predictions_file, t.data.get("columns"), label)
        candidates = _precomputed.in_column_order(candidates, names, label)
    else:
        if "columns" in t.data:
            raise t.error("columns", "no columns without design.predictions", t.data["columns"])
        parameters = _parameters(root)
        model = _model(root, path.parent)
        if model.function is None:
            raise ProjectError(f"{label}: model.function: expected a model function for a design "
                               "(or design.predictions, a file of precomputed predictions)")
        sampling = _sampling(root, parameters)
        function = import_function(model.function, model.path, label, "model.function")
    sensors = tuple(Sensor(c.name, 0.0, type=c.type, location=c.location, unit=c.unit) for c in candidates)
    sources = resolve_sources(_uncertainty(root), sensors, tuple(range(len(sensors))), label)
    k = t.get("k", "int", len(candidates), what=f"a number of sensors in 1..{len(candidates)}")
    if not 1 <= k <= len(candidates):
        raise t.error("k", f"a number of sensors in 1..{len(candidates)} (the candidate locations)", k)
    budget = t.get("budget", "positive", None)
    tolerance = t.get("tolerance", "number", None, what="a gain in bits >= 0")
    if tolerance is not None and tolerance < 0:
        raise t.error("tolerance", "a gain in bits >= 0", t.data["tolerance"])
    n_sim = t.get("n_simulations", "int", 1000, what="a positive integer")
    if n_sim < 1:
        raise t.error("n_simulations", "a positive integer", n_sim)
    fixed = _fixed(t, candidates)
    max_per_type = t.get("max_per_type", "table", None, what="a table of sensor type = most sensors")
    if max_per_type is not None:
        types = {c.type for c in candidates}
        for key, value in max_per_type.items():
            if key not in types:
                raise t.error("max_per_type", f"sensor types of the candidates ({', '.join(sorted(types))})", key)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise t.error("max_per_type", f"a number of sensors >= 0 for {key!r}", value)
    _fixed_within_limits(t, candidates, fixed, k, budget, max_per_type)
    return DesignProject(
        **ident, sampling=sampling, candidates=candidates,
        uncertainty=sources, model_function=function, model_options=model.options if model else {},
        batch_size=model.batch_size if model else 0, k=k, budget=budget, tolerance=tolerance, n_simulations=n_sim,
        fixed=fixed, max_per_type=max_per_type, predictions_file=predictions_file,
        model_ref=model.function if model else "",
        inputs=(path, candidates_file, *_precomputed.files(predictions_file, t.data.get("columns"))),
    )


def _fixed_within_limits(t, candidates, fixed, k, budget, max_per_type) -> None:
    """The checks :func:`place_sensors` makes of ``budget``, ``k`` and
    ``max_per_type`` against the fixed sensors (the same rules), made when the
    project is read so that the message names the file and the keys."""
    def where(key: str) -> str:
        return f"{t.file}: {t.path(key)}"

    if budget is not None:
        costs = [c.cost for c in candidates]
        problem = _checks.budget_problem(costs, fixed, budget)
        if problem is not None:
            what, cost = problem
            least = ("the cost of the cheapest candidate location" if what == "cheapest"
                     else f"the cost of the {len(fixed)} sensors of {t.path('fixed')}")
            raise ProjectError(f"{where('budget')}: expected at least {cost} ({least}), got {budget}")
    if _checks.too_few_for_fixed(k, fixed):
        raise ProjectError(f"{where('k')}: expected at least {len(fixed)} (the sensors of {t.path('fixed')}), "
                           f"got {k}")
    if max_per_type is not None:
        below = _checks.quota_below_fixed(max_per_type, [c.type for c in candidates], fixed)
        if below is not None:
            kind, used, quota = below
            raise ProjectError(f"{where('max_per_type')}: expected at least {used} for {kind!r} (the sensors of "
                               f"type {kind!r} in {t.path('fixed')}), got {quota}")


def _fixed(t, candidates) -> tuple[int, ...]:
    """Indices of the ``fixed`` candidate names (each named once)."""
    names = t.get("fixed", "list", [], what="a list of candidate names")
    if not all(isinstance(f, str) for f in names):
        raise t.error("fixed", "a list of candidate names (strings)", names)
    index = {c.name: i for i, c in enumerate(candidates)}
    unknown = [f for f in names if f not in index]
    if unknown:
        raise t.error("fixed", "names of candidate locations", unknown[0])
    twice = [f for i, f in enumerate(names) if f in names[:i]]
    if twice:
        raise ProjectError(f"{t.file}: {t.path('fixed')}: expected distinct candidate names, got {twice[0]!r} "
                           "more than once")
    return tuple(index[f] for f in names)
