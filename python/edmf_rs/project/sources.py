"""The project's [[uncertainty]] sources as frozen ``scipy.stats`` distributions,
combined per sensor into U_c (Eq. 4).

A source covers all sensors, a list of them, or the sensors of one type; it
adds nothing at the sensors it does not cover. So U_c is combined sensor by
sensor with :func:`edmf_rs.combine` from the sources covering that sensor:
exact at the sensors whose sources are all normal (or that have a single
source), Monte Carlo samples elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..engine import intervals
from ..engine.distributions import distribution
from ..engine.uncertainty import CombinedUncertainty, combine, relative_to_measured
from .schema import ProjectError, Sensor, UncertaintySpec


def frozen(distribution: str, values: tuple[float, float]):
    """normal (mean, sd) or uniform (low, high) as a scalar frozen scipy.stats distribution."""
    a, b = values
    return stats.norm(a, b) if distribution == "normal" else stats.uniform(a, b - a)


@dataclass(frozen=True)
class UncertaintySource:
    """One [[uncertainty]] source resolved against the sensors of the identification.

    ``values`` are (mean, sd) of a normal or (low, high) of a uniform; with
    ``relative_to = "measured"`` they are fractions of each sensor's measured
    value. ``sensors`` are the indices of the sensors it covers.
    """

    name: str
    kind: str
    distribution: str
    values: tuple[float, float]
    relative_to: str
    sensors: tuple[int, ...]
    params: tuple = ()
    key: str = ""  # where it is in the project file, e.g. "uncertainty[2]"

    def base(self):
        """The scalar frozen distribution of the value (or of the fraction of the measured value)."""
        if self.distribution not in ("normal", "uniform"):
            return distribution(self.distribution, dict(self.params))
        return frozen(self.distribution, self.values)

    def per_sensor(self, measured: np.ndarray) -> list[tuple[int, object]]:
        """(sensor index, scalar frozen distribution) for every covered sensor."""
        if not self.sensors:
            return []
        if self.relative_to == "absolute":
            return [(j, self.base()) for j in self.sensors]
        vectorised = relative_to_measured(self.base(), measured[np.asarray(self.sensors)])
        return list(zip(self.sensors, intervals.split(vectorised, len(self.sensors))))

    def describe(self) -> str:
        if self.distribution in ("normal", "uniform"):
            a, b = self.values
            text = f"normal(mean {a:g}, sd {b:g})" if self.distribution == "normal" else f"uniform({a:g}, {b:g})"
        else:
            text = f"{self.distribution}({', '.join(f'{k} {v:g}' for k, v in self.params)})"
        return text + (" x measured value" if self.relative_to == "measured" else "")


def resolve_sources(specs: tuple[UncertaintySpec, ...], sensors: tuple[Sensor, ...],
                    kept: tuple[int, ...], label: str) -> tuple[UncertaintySource, ...]:
    """Sources with their sensor selections checked against the measurements.

    ``sensors`` are all sensors of the measurements; ``kept`` those the
    identification uses (excluded sensors may be named, they are skipped).
    """
    position = {sensors[i].name: k for k, i in enumerate(kept)}
    names = {s.name for s in sensors}
    result = []
    for spec in specs:
        where = f"{label}: {spec.key}.sensors (source '{spec.name}')"
        if spec.sensors == "all":
            covered = tuple(range(len(kept)))
        elif isinstance(spec.sensors, dict):
            kind = spec.sensors["type"]
            types = sorted({s.type for s in sensors if s.type})
            if kind not in types:
                raise ProjectError(f"{where}: expected a sensor type of the measurements "
                                   f"({', '.join(types) or 'none given: add a type column'}), got {kind!r}")
            covered = tuple(k for k, i in enumerate(kept) if sensors[i].type == kind)
        else:
            unknown = [n for n in spec.sensors if n not in names]
            if unknown:
                raise ProjectError(f"{where}: sensor '{unknown[0]}' is not in the measurements "
                                   f"(expected one of: {', '.join(s.name for s in sensors)})")
            covered = tuple(sorted({position[n] for n in spec.sensors if n in position}))
        result.append(UncertaintySource(spec.name, spec.kind, spec.distribution, spec.values,
                                        spec.relative_to, covered, spec.params, spec.key))
    uncovered = sorted(set(range(len(kept))) - {j for src in result for j in src.sensors})
    if uncovered:
        name = sensors[kept[uncovered[0]]].name
        raise ProjectError(f"{label}: uncertainty: sensor '{name}' is covered by no [[uncertainty]] source; "
                           "expected at least one (e.g. its measurement noise), else its thresholds have zero width")
    return tuple(result)


def check_relative(sources: tuple[UncertaintySource, ...], sensors: tuple[Sensor, ...], label) -> None:
    """Refuses sources relative to a measured value that cannot be: a fraction of 0
    (no spread, when no other source covers the sensor) or an asymmetric family
    (e.g. lognorm) at a reading <= 0. ``sensors`` are those the identification uses."""
    for j, sensor in enumerate(sensors):
        covering = [src for src in sources if j in src.sensors]
        relative = [src for src in covering if src.relative_to == "measured"]
        for src in relative:
            if sensor.value <= 0 and not intervals.is_symmetric(src.base()):
                raise ProjectError(
                    f"{label}: {src.key or 'uncertainty'}: source '{src.name}' ({src.describe()}) is relative to "
                    f"the measured value, and sensor '{sensor.name}' is measured as {sensor.value:g}: a "
                    f"{src.distribution} fraction needs a positive measured value (only symmetric families stay "
                    "in their family when it is <= 0); give that sensor a source with an absolute value "
                    f"(relative_to = \"absolute\") or a symmetric distribution, or leave it out "
                    f"(exclude = [\"{sensor.name}\"] under [measurements])")
        if sensor.value == 0 and relative and len(relative) == len(covering):
            listed = ", ".join(f"'{src.name}' ({src.key})" if src.key else f"'{src.name}'" for src in relative)
            raise ProjectError(
                f"{label}: uncertainty: sensor '{sensor.name}' is measured as 0, and every source covering it is "
                f"relative to the measured value ({listed}): a fraction of 0 has no spread, so its combined "
                "uncertainty would be zero and its threshold bounds of zero width; give it a source with an "
                "absolute value (relative_to = \"absolute\", e.g. the sensor's noise), or leave it out "
                f"(exclude = [\"{sensor.name}\"] under [measurements])")


def combine_sources(sources: tuple[UncertaintySource, ...], measured: np.ndarray, *,
                    n_samples: int = 200_000, seed: int = 0, streams=None,
                    sensor_names=None) -> CombinedUncertainty:
    """U_c per sensor: the sum of the model sources minus the measurement sources covering it.

    Each sensor's Monte Carlo samples come from its own random stream, keyed by
    ``streams[j]`` (the sensor's index among all sensors, so leaving a sensor
    out does not change the others' samples). Sensors whose sources are all
    normal, or that have a single source, keep their exact U_c (the
    ``marginals``) even when other sensors need samples.
    """
    n_m = len(measured)
    model: list[list] = [[] for _ in range(n_m)]
    measurement: list[list] = [[] for _ in range(n_m)]
    names = tuple(sensor_names) if sensor_names is not None else None
    for src in sources:
        try:
            resolved = src.per_sensor(measured)
        except ValueError as exc:
            bad = [j for j in src.sensors if measured[j] <= 0]
            at = f" at sensor '{names[bad[0]]}' ({measured[bad[0]]:g})" if bad and names is not None else ""
            raise ValueError(f"source '{src.name}'{at}: {exc}") from None
        for j, dist in resolved:
            (model if src.kind == "model" else measurement)[j].append(dist)
    streams = range(n_m) if streams is None else streams
    rngs = [np.random.default_rng([seed, int(k)]) for k in streams]
    per_sensor = []
    for j in range(n_m):
        try:
            per_sensor.append(combine(model=model[j], measurement=measurement[j], n_sensors=1,
                                      n_samples=n_samples, seed=rngs[j]))
        except ValueError as exc:  # combined one sensor at a time: its messages say "sensor 0"
            where = f"sensor '{names[j]}'" if names is not None else f"sensor {j}"
            raise ValueError(f"{where}: {str(exc).replace(' at sensor 0', '')}") from None
    mean = np.array([c.mean[0] for c in per_sensor])
    std = np.array([c.std[0] for c in per_sensor])
    if all(c.exact for c in per_sensor):
        return CombinedUncertainty(n_m, distribution=stats.norm(loc=mean, scale=std), seed=seed,
                                   gaussian=np.ones(n_m, dtype=bool), symmetric=np.ones(n_m, dtype=bool),
                                   sensor_names=names)
    # Samples for every sensor (the phi-sensitivity diagnostics use them); the
    # thresholds of sensors with an exact marginal come from the closed form.
    samples = np.column_stack([
        c.samples[:, 0] if not c.exact else rngs[j].normal(mean[j], std[j], n_samples)
        for j, c in enumerate(per_sensor)
    ])
    marginals = tuple((1.0, stats.norm(mean[j], std[j])) if c.exact else c.marginals[0]
                      for j, c in enumerate(per_sensor))
    return CombinedUncertainty(
        n_m, samples=samples, marginals=marginals, seed=seed, sensor_names=names,
        symmetric=np.array([bool(c.symmetric[0]) for c in per_sensor]),
        gaussian=np.array([c.exact or bool(c.gaussian[0]) for c in per_sensor]),
        sources=tuple(c.sources[0] if c.sources is not None else ((1.0, stats.norm(mean[j], std[j])),)
                      for j, c in enumerate(per_sensor)),
    )
