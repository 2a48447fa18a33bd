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

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..engine.sampling import Sampling
from ..engine.uncertainty import CombinedUncertainty
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
from . import _precomputed

TOP_LEVEL = ("identification", "parameters", "sampling", "model", "uncertainty", "design")


@dataclass(frozen=True)
class Candidate:
    """One candidate sensor location."""

    name: str
    type: str
    location: float | None
    cost: float
    load_case: str = ""
    unit: str = ""


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

    @property
    def costs(self) -> np.ndarray:
        return np.array([c.cost for c in self.candidates])

    def predictions(self) -> np.ndarray:
        """(N, L) predictions of every instance at every candidate, checked against the candidates
        (a read-only memory map, not copied, for a .npy predictions file)."""
        names = [c.name for c in self.candidates]
        if self.predictions_file is not None:
            return _precomputed.load_predictions(self.predictions_file, len(names), str(self.file))
        parts = []
        for theta in self.sampling.batches(self.batch_size):
            out = self.model_function(theta, **self.model_options)
            parts.append(_columns(out, names, theta.shape[0], self.file))
        g = np.concatenate(parts)
        bad = np.flatnonzero(~np.isfinite(g).all(axis=0))
        if bad.size:
            raise ProjectError(f"{self.file}: model.function: non-finite predictions at location "
                               f"'{names[bad[0]]}'; expected finite predictions at every candidate")
        return g

    def combined_uncertainty(self, predictions: np.ndarray) -> CombinedUncertainty:
        """U_c of every candidate (Eq. 4); "measured" values are the mean predictions."""
        return combine_sources(self.uncertainty, predictions.mean(axis=0), n_samples=self.n_samples,
                               seed=self.seed)


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


def read_candidates(file: Path, label: str) -> tuple[Candidate, ...]:
    """The candidate locations CSV: name, type, location, cost, load_case, unit (name and type required)."""
    try:
        with open(file, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    except FileNotFoundError:
        raise ProjectError(f"{label}: design.candidates: no such file '{file}'") from None
    if not rows:
        raise ProjectError(f"{file}: expected a header (name,type,location,cost) and at least one location")
    for col in ("name", "type"):
        if col not in rows[0]:
            raise ProjectError(f"{file}: expected a column '{col}' (columns: name, type, location, cost)")
    result, seen = [], set()
    for line, r in enumerate(rows, start=2):
        name = (r.get("name") or "").strip()
        if not name or name in seen:
            raise ProjectError(f"{file}: line {line}: expected a unique location name, got {name!r}")
        seen.add(name)
        cost = _number(r.get("cost"), 1.0, file, line, "cost")
        if not cost > 0:
            raise ProjectError(f"{file}: line {line}: cost: expected a cost > 0, got {cost}")
        location = _number(r.get("location"), None, file, line, "location")
        result.append(Candidate(name, (r.get("type") or "").strip(), location, cost,
                                (r.get("load_case") or "").strip(), (r.get("unit") or "").strip()))
    return tuple(result)


def _number(text, default, file, line, column):
    if text is None or not text.strip():
        return default
    try:
        value = float(text)
    except ValueError:
        raise ProjectError(f"{file}: line {line}: {column}: expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise ProjectError(f"{file}: line {line}: {column}: expected a finite number, got {text!r}")
    return value


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
    candidates = read_candidates(path.parent / t.get("candidates", "str", what="a CSV file of candidate locations"),
                                 label)
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
    tolerance = t.get("tolerance", "number", None)
    n_sim = t.get("n_simulations", "int", 1000, what="a positive integer")
    if n_sim < 1:
        raise t.error("n_simulations", "a positive integer", n_sim)
    fixed_names = t.get("fixed", "list", [], what="a list of candidate names")
    index = {c.name: i for i, c in enumerate(candidates)}
    unknown = [f for f in fixed_names if f not in index]
    if unknown:
        raise t.error("fixed", "names of candidate locations", unknown[0])
    max_per_type = t.get("max_per_type", "table", None, what="a table of sensor type = most sensors")
    if max_per_type is not None:
        types = {c.type for c in candidates}
        for key, value in max_per_type.items():
            if key not in types:
                raise t.error("max_per_type", f"sensor types of the candidates ({', '.join(sorted(types))})", key)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise t.error("max_per_type", f"a number of sensors >= 0 for {key!r}", value)
    return DesignProject(
        **ident, sampling=sampling, candidates=candidates,
        uncertainty=sources, model_function=function, model_options=model.options if model else {},
        batch_size=model.batch_size if model else 0, k=k, budget=budget, tolerance=tolerance, n_simulations=n_sim,
        fixed=tuple(index[f] for f in fixed_names), max_per_type=max_per_type, predictions_file=predictions_file,
    )
