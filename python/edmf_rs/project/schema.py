"""The project file (TOML): reading and checking every table.

Longer than 450 lines: one reader per table of the file, kept together so the
format reads top to bottom as the project file does.

Each check names the file, the dotted key (``parameters.E.low``) and what was
expected, in one :class:`ProjectError`; nothing here reads other files or
imports the model (see :mod:`edmf_rs.project.inputs`).
"""

from __future__ import annotations

import codecs
from dataclasses import dataclass, field
from pathlib import Path

from ..engine.sampling import METHODS, Parameter, Sampling, grid, latin_hypercube, sobol
from ..simulators.command import CommandSpec
from .identification import IdentificationTable, identification, load_toml
from .table import ProjectError, Table

__all__ = ["ModelSpec", "PrognosisSpec", "ProjectError", "ProjectSpec", "Sensor", "UncertaintySpec", "read_spec"]

DISTRIBUTIONS = {"normal": ("mean", "sd"), "uniform": ("low", "high")}


@dataclass(frozen=True)
class Sensor:
    """One measurement y_i: the sensor's name, measured value, and optional type, location and unit."""

    name: str
    value: float
    type: str = ""
    location: float | None = None
    unit: str = ""


@dataclass(frozen=True)
class ModelSpec:
    """[model]: a vectorised function ``module:function``, or precomputed instances."""

    function: str | None = None
    path: Path | None = None
    options: dict = field(default_factory=dict)
    predictions: Path | None = None
    parameters: Path | None = None
    nan: str = "raise"
    batch_size: int = 10_000
    sensors: tuple[str, ...] | None = None  # the sensor of each column of a bare array, in order
    command: CommandSpec | None = None   # an external program (see edmf_rs.simulators)
    workers: int = 1
    store: bool = True                   # keep every evaluated instance in <out>/store
    max_failure_rate: float | None = None
    stop_after_failures: int = 5          # stop when the first N instances all fail
    scheduler: str | None = None          # [compute] scheduler: a Dask scheduler evaluating the function


@dataclass(frozen=True)
class UncertaintySpec:
    """One [[uncertainty]] source as written; ``sensors`` is "all", a list of names or {type = ...}."""

    key: str
    name: str
    kind: str
    distribution: str
    values: tuple[float, float]  # (mean, sd) or (low, high); () for the other families
    relative_to: str
    sensors: object
    params: tuple = ()  # (name, value) pairs: the shorthand's keys or the scipy.stats parameters


@dataclass(frozen=True)
class PrognosisSpec:
    """One [[prognosis]]: a quantity of interest evaluated on the candidates."""

    key: str
    name: str
    function: str
    path: Path
    options: dict
    unit: str
    uncertainty: tuple[str, tuple[float, float]] | None
    probability: float


@dataclass(frozen=True)
class ProjectSpec(IdentificationTable):
    """The project file, checked on its own (other files not read yet)."""

    parameters: tuple[Parameter, ...]
    sampling: Sampling | None
    model: ModelSpec
    measurements_file: Path | None
    inline_sensors: tuple[Sensor, ...]
    exclude: tuple[str, ...]
    uncertainty: tuple[UncertaintySpec, ...]
    prognosis: tuple[PrognosisSpec, ...]
    decimal: str = "."        # of the measurements file
    encoding: str = "utf-8"   # of the measurements file


TOP_LEVEL = ("identification", "parameters", "sampling", "model", "measurements", "sensors",
             "uncertainty", "prognosis", "compute")


def read_spec(path: str | Path) -> ProjectSpec:
    """Reads and checks a project file; raises :class:`ProjectError` on the first problem."""
    path = Path(path)
    label = str(path)
    root = load_toml(path)
    root.check_keys(TOP_LEVEL)
    base = path.parent
    ident = identification(root, path)

    parameters = _parameters(root)
    model = _compute(root, _model(root, base))
    if model.predictions is not None:
        if "sampling" in root.data:
            raise ProjectError(f"{label}: sampling: not used when model.predictions gives the instances; "
                               "remove [sampling]")
        sampling = None
    else:
        sampling = _sampling(root, parameters)
        if model.scheduler is not None and sampling.method == "adaptive":
            raise ProjectError(f"{label}: compute.scheduler: not with method = \"adaptive\" (its waves run "
                               "the model in this process); remove [compute] or use sobol, lhs or grid")

    measurements_file, inline, exclude, decimal, encoding = _measurements(root, base)
    return ProjectSpec(
        **ident, parameters=parameters, sampling=sampling, model=model,
        measurements_file=measurements_file, inline_sensors=inline, exclude=exclude,
        uncertainty=_uncertainty(root), prognosis=_prognosis(root, base), decimal=decimal, encoding=encoding,
    )



def _parameters(root: Table) -> tuple[Parameter, ...]:
    table = root.table("parameters")
    if not table.data:
        raise table.error("", "at least one [parameters.NAME] table with low and high", {})
    result = []
    for name in table.data:
        t = table.table(name)
        t.check_keys(("low", "high", "unit", "scale"))
        low = t.get("low", "number", what="the lower bound of the domain, a number")
        high = t.get("high", "number", what="the upper bound of the domain, a number")
        unit, scale = t.get("unit", "str", ""), t.get("scale", "choice", "linear", choices=("linear", "log"))
        try:  # (outside: ProjectError is a ValueError, and its message names the file already)
            result.append(Parameter(name, low, high, unit=unit, scale=scale))
        except ValueError as exc:
            raise ProjectError(f"{root.file}: parameters.{exc}") from None
    return tuple(result)


def _sampling(root: Table, parameters: tuple[Parameter, ...]) -> Sampling:
    t = root.table("sampling")
    if t.data.get("method") == "adaptive":  # issue 16: options read by the adaptive package
        from .adaptive import adaptive_sampling

        return adaptive_sampling(t, parameters)
    t.check_keys(("method", "n", "points", "seed"))
    method = t.get("method", "choice", choices=(*METHODS, "adaptive"))
    if method == "grid":
        if "n" in t.data:
            raise t.error("n", "no n for a grid (give points = {NAME = count})", t.data["n"])
        points = t.table("points")
        points.check_keys(tuple(p.name for p in parameters))
        counts = {p.name: points.get(p.name, "int", what="a number of grid points >= 1") for p in parameters}
        for name, count in counts.items():
            if count < 1:
                raise points.error(name, "a number of grid points >= 1", count)
        try:
            return grid(parameters, counts)
        except ValueError as exc:
            raise ProjectError(f"{root.file}: sampling.{exc}") from None
    if "points" in t.data:
        raise t.error("points", f"no points for method = '{method}' (give n)", t.data["points"])
    n = t.get("n", "int", what="the number of model instances, an integer >= 1")
    if n < 1:
        raise t.error("n", "the number of model instances, an integer >= 1", n)
    seed = t.get("seed", "seed", 0)
    try:
        return (latin_hypercube if method == "lhs" else sobol)(parameters, n, seed=seed)
    except ValueError as exc:
        raise ProjectError(f"{root.file}: sampling.{exc}") from None


def _function_ref(t: Table, key: str) -> str:
    ref = t.get(key, "str", what="'module:function'")
    module, sep, func = ref.partition(":")
    if not sep or not module.strip() or not func.strip():
        raise t.error(key, "'module:function' (e.g. 'girder:predict')", ref)
    return ref


COMMAND_KEYS = ("command", "files", "output", "timeout", "keep_work")
RUN_KEYS = ("workers", "store", "max_failure_rate", "stop_after_failures")


def _model(root: Table, base: Path) -> ModelSpec:
    t = root.table("model")
    t.check_keys(("function", "path", "options", "predictions", "parameters", "nan", "batch_size", "sensors",
                  *COMMAND_KEYS, *RUN_KEYS))
    sensors = None
    if "sensors" in t.data:
        sensors = t.get("sensors", "list", what="a list of sensor names, one per column the model returns")
        if not sensors or not all(isinstance(x, str) and x for x in sensors):
            raise t.error("sensors", "a list of sensor names, one per column the model returns", sensors)
        twice = sorted({x for x in sensors if sensors.count(x) > 1})
        if twice:
            raise t.error("sensors", "distinct sensor names", twice[0] + " twice")
        sensors = tuple(sensors)
    nan = t.get("nan", "choice", "raise", choices=("raise", "falsify"))
    batch_size = t.get("batch_size", "int", 10_000, what="a positive integer")
    if batch_size < 1:
        raise t.error("batch_size", "a positive integer", batch_size)
    kinds = [k for k in ("function", "command", "predictions") if k in t.data]
    if len(kinds) > 1:
        raise t.error(kinds[1], f"one of function, command or predictions, not both {kinds[0]} and {kinds[1]}",
                      t.data[kinds[1]])
    if not kinds:
        raise t.error("function", "function = 'module:function', command = [\"program\", ...], or "
                      "predictions = 'file' with parameters = 'file'")
    run = _run_options(t)
    if "command" not in t.data:
        for key in COMMAND_KEYS:
            if key in t.data:
                raise t.error(key, f"no {key} without command = [...]", t.data[key])
    if "command" in t.data:
        for key in ("parameters",):
            if key in t.data:
                raise t.error(key, "no parameters file with command (the [sampling] gives them)", t.data[key])
        return ModelSpec(command=_command(t, base), path=base / t.get("path", "str", "."),
                         options=t.get("options", "table", {}), nan=nan, batch_size=batch_size, sensors=sensors,
                         **run)
    if "function" in t.data:
        if "parameters" in t.data:
            raise t.error("parameters", "no parameters file with function (the [sampling] gives them)",
                          t.data["parameters"])
        return ModelSpec(function=_function_ref(t, "function"), path=base / t.get("path", "str", "."),
                         options=t.get("options", "table", {}), nan=nan, batch_size=batch_size, sensors=sensors,
                         **run)
    for key in ("path", "options", *RUN_KEYS):
        if key in t.data:
            raise t.error(key, f"no {key} with predictions (only with function or command)", t.data[key])
    predictions = base / t.get("predictions", "str", what="a .npy, .csv or .parquet file")
    parameters = base / t.get("parameters", "str", what="the parameters of the precomputed instances "
                                                        "(a .npy, .csv or .parquet file)")
    for key, file in (("predictions", predictions), ("parameters", parameters)):
        if file.suffix.lower() not in (".npy", ".csv", ".parquet"):
            raise t.error(key, "a .npy, .csv or .parquet file", t.data[key])
    if sensors is not None and predictions.suffix.lower() != ".npy":
        raise t.error("sensors", f"no sensors list with a {predictions.suffix} file (its columns are named; "
                      "sensors gives the columns of a .npy array)", list(sensors))
    return ModelSpec(predictions=predictions, parameters=parameters, nan=nan, batch_size=batch_size,
                     sensors=sensors)


def _compute(root: Table, model: ModelSpec) -> ModelSpec:
    """[compute] scheduler = "tcp://host:8786": the Dask cluster that evaluates a Python function model."""
    from dataclasses import replace

    t = root.table("compute", {})
    t.check_keys(("scheduler",))
    if "scheduler" not in t.data:
        return model
    scheduler = t.get("scheduler", "str", what="a Dask scheduler address, e.g. \"tcp://10.0.0.5:8786\"")
    if not scheduler.strip():
        raise t.error("scheduler", "a Dask scheduler address, e.g. \"tcp://10.0.0.5:8786\"", scheduler)
    if model.function is None:
        raise t.error("scheduler", "a scheduler only with model.function (a Python model; external "
                      "programs run in local workers, precomputed instances need no model)", scheduler)
    return replace(model, scheduler=scheduler.strip())


def _run_options(t: Table) -> dict:
    """workers, store and the failure limits of [model]."""
    workers = t.get("workers", "int", 1, what="a number of parallel runs >= 1")
    if workers < 1:
        raise t.error("workers", "a number of parallel runs >= 1", workers)
    store = t.get("store", "bool", True)
    rate = t.get("max_failure_rate", "number", None, what="a fraction of failed instances in [0, 1]")
    if rate is not None and not 0.0 <= rate <= 1.0:
        raise t.error("max_failure_rate", "a fraction of failed instances in [0, 1]", rate)
    first = t.get("stop_after_failures", "int", 5, what="a number of instances >= 0 (0: never stop early)")
    if first < 0:
        raise t.error("stop_after_failures", "a number of instances >= 0 (0: never stop early)", first)
    return {"workers": workers, "store": store, "max_failure_rate": rate, "stop_after_failures": first}


def _command(t: Table, base: Path) -> CommandSpec:
    """[model] command, files, output, timeout, keep_work (an external program)."""
    command = t.data["command"]
    if isinstance(command, str):
        command = command.split()
    if not isinstance(command, list) or not command or not all(isinstance(a, str) for a in command):
        raise t.error("command", "a list of strings: the program and its arguments, e.g. [\"ccx\", \"-i\", "
                      "\"girder\"]", t.data["command"])
    files = t.get("files", "list", [], what="a list of template file names")
    if not all(isinstance(f, str) for f in files):
        raise t.error("files", "a list of template file names", files)
    output = t.data.get("output", {"file": "results.csv"})
    if isinstance(output, str):
        output = {"file": output}
    out = Table(t.file, t.path("output"), output)
    out.check_keys(("file", "parser"))
    file = out.get("file", "str", what="the name of the file the program writes")
    parser = _function_ref(out, "parser") if "parser" in out.data else None
    if parser is None and Path(file).suffix.lower() not in (".csv", ".json"):
        raise out.error("parser", f"'module:function' to read '{file}' (built in: .csv with sensor,value "
                        "and .json {sensor: value})")
    timeout = t.get("timeout", "positive", None, what="seconds per run, a positive number")
    keep = t.get("keep_work", "bool", False)
    return CommandSpec(tuple(command), tuple(files), file, parser, base / t.get("path", "str", "."), timeout,
                       keep)


def _measurements(root: Table, base: Path):
    """(file, inline sensors, excluded names, decimal separator, encoding)."""
    t = root.table("measurements", {})
    t.check_keys(("file", "sensors", "exclude", "decimal", "encoding"))
    decimal = t.get("decimal", "choice", ".", choices=(".", ","))
    encoding = t.get("encoding", "str", "utf-8", what="a text encoding (e.g. \"utf-8\", \"latin-1\")")
    try:
        codecs.lookup(encoding)
    except LookupError:
        raise t.error("encoding", "a text encoding Python knows (e.g. \"utf-8\", \"latin-1\")", encoding) from None
    for key in ("decimal", "encoding"):
        if key in t.data and "file" not in t.data:
            raise t.error(key, f"no {key} without a measurements file", t.data[key])
    inline = tuple(t.tables("sensors")) + tuple(root.tables("sensors"))
    if ("file" in t.data) == bool(inline):
        raise t.error("file", "either file = 'measurements.csv' or inline [[measurements.sensors]] tables"
                      + (", not both" if inline else ""))
    exclude = t.get("exclude", "list", [], what="a list of sensor names")
    if not all(isinstance(s, str) for s in exclude):
        raise t.error("exclude", "a list of sensor names", exclude)
    twice = sorted({s for s in exclude if exclude.count(s) > 1})
    if twice:
        raise t.error("exclude", f"each sensor name once ({', '.join(twice)} more than once)", exclude)
    file = base / t.get("file", "str", what="a CSV file") if "file" in t.data else None
    sensors = []
    for s in inline:
        s.check_keys(("name", "value", "type", "location", "unit"))
        location = s.get("location", "number", None)
        sensors.append(Sensor(s.get("name", "str", what="the sensor's name"), s.get("value", "number"),
                              type=s.get("type", "str", ""), location=location, unit=s.get("unit", "str", "")))
    return file, tuple(sensors), tuple(exclude), decimal, encoding


def distribution_values(t: Table, distribution: str, *, absolute_only: bool = False) -> tuple[float, float]:
    """(mean, sd) of a normal or (low, high) of a uniform, with the keys of the other family refused."""
    wanted = DISTRIBUTIONS[distribution]
    for other in {k for v in DISTRIBUTIONS.values() for k in v} - set(wanted):
        if other in t.data:
            raise t.error(other, f"no {other} for a {distribution} distribution (give {' and '.join(wanted)})",
                          t.data[other])
    if distribution == "normal":
        return t.get("mean", "number", 0.0), t.get("sd", "positive", what="a standard deviation > 0")
    low = t.get("low", "number", what="the lower bound, a number")
    high = t.get("high", "number", what="the upper bound, a number")
    if not low < high:
        raise t.error("high", f"a number above low ({low:g})", high)
    return low, high


def _source_distribution(t: Table, name: str) -> tuple[str, tuple, tuple]:
    """(distribution, values, params) of one [[uncertainty]] source, checked by freezing it."""
    from ..engine.distributions import SHORTHANDS, accepted_parameters, distribution

    family = t.get("distribution", "str", what="'normal', 'uniform', 'triangular', 'truncated_normal' or "
                                               "a continuous scipy.stats distribution name (e.g. 'lognorm')")
    where = f"{t.file}: {t.path('distribution')} (source '{name}')"
    try:
        accepted = accepted_parameters(family)
    except ValueError as exc:
        raise ProjectError(f"{where}: {str(exc).removeprefix('distribution: ')}") from None
    all_short = {k for v in SHORTHANDS.values() for k in v}
    if family in DISTRIBUTIONS:  # normal and uniform: checked key by key, as always
        for key in ("mode", "params"):
            if key in t.data:
                raise t.error(key, f"no {key} for a {family} distribution (give {' and '.join(accepted)})",
                              t.data[key])
        values = distribution_values(t, family)
        return family, values, tuple(zip(DISTRIBUTIONS[family], values))
    if family in SHORTHANDS:
        if "params" in t.data:
            raise t.error("params", f"no params for {family} (give {', '.join(accepted)})", t.data["params"])
        for key in all_short - set(accepted):
            if key in t.data:
                raise t.error(key, f"no {key} for a {family} distribution (give {', '.join(accepted)})", t.data[key])
        params = {k: t.data[k] for k in accepted if k in t.data}
        key = t.path("")
    else:
        for key in all_short:
            if key in t.data:
                raise t.error(key, f"params = {{ ... }} with the parameters of {family} ({', '.join(accepted)})",
                              t.data[key])
        params = t.get("params", "table", what=f"a table of the parameters of {family} ({', '.join(accepted)})")
        key = t.path("params")
    try:
        distribution(family, params)
    except ValueError as exc:
        raise ProjectError(f"{t.file}: {key} (source '{name}'): {str(exc).removeprefix('params: ')}") from None
    return family, (), tuple((k, float(v)) for k, v in params.items())


def _uncertainty(root: Table) -> tuple[UncertaintySpec, ...]:
    tables = root.tables("uncertainty")
    if not tables:
        raise root.error("uncertainty", "at least one [[uncertainty]] source (e.g. the sensors' noise)")
    result, names = [], set()
    for t in tables:
        t.check_keys(("name", "kind", "distribution", "mean", "sd", "low", "high", "mode", "params",
                      "relative_to", "sensors"))
        name = t.get("name", "str", t.key)
        if name in names:
            raise t.error("name", "a name no other [[uncertainty]] source has", name)
        names.add(name)
        distribution, values, params = _source_distribution(t, name)
        sensors = t.data.get("sensors", "all")
        if not (sensors == "all" or (isinstance(sensors, list) and sensors and all(isinstance(s, str) for s in sensors))
                or (isinstance(sensors, dict) and list(sensors) == ["type"] and isinstance(sensors["type"], str))):
            raise t.error("sensors", "\"all\", a list of sensor names or {type = \"...\"}", sensors)
        result.append(UncertaintySpec(
            key=t.key, name=name, kind=t.get("kind", "choice", choices=("model", "measurement")),
            distribution=distribution, values=values,
            relative_to=t.get("relative_to", "choice", "absolute", choices=("absolute", "measured")),
            sensors=sensors, params=params,
        ))
    return tuple(result)


def _prognosis(root: Table, base: Path) -> tuple[PrognosisSpec, ...]:
    result = []
    for t in root.tables("prognosis"):
        t.check_keys(("name", "function", "path", "options", "unit", "distribution", "mean", "sd", "low", "high",
                      "probability"))
        uncertainty = None
        if "distribution" in t.data:
            distribution = t.get("distribution", "choice", choices=tuple(DISTRIBUTIONS))
            uncertainty = (distribution, distribution_values(t, distribution))
        else:
            for key in ("mean", "sd", "low", "high"):
                if key in t.data:
                    raise t.error("distribution", f"'normal' or 'uniform' (since {key} is given)")
        probability = t.get("probability", "number", 0.95, what="a probability in (0, 1)")
        if not 0.0 < probability < 1.0:
            raise t.error("probability", "a probability in (0, 1)", probability)
        result.append(PrognosisSpec(
            key=t.key, name=t.get("name", "str"), function=_function_ref(t, "function"),
            path=base / t.get("path", "str", "."), options=t.get("options", "table", {}),
            unit=t.get("unit", "str", ""), uncertainty=uncertainty, probability=probability,
        ))
    return tuple(result)
