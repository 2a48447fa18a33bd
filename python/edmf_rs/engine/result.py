"""The outcome of falsifying a set of model instances (Sec. 3.1 and 3.3)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .candidate_set import CandidateSegments, LazyIndices
from .thresholds import Thresholds


@dataclass(frozen=True, eq=False)
class FalsificationResult:
    """Candidate model set and diagnostics, as returned by `falsify` and `falsify_model`.

    Attributes
    ----------
    thresholds : Thresholds
        The bounds the instances were judged against (Eq. 8).
    measurements : numpy.ndarray
        The measured values y.
    n_instances : int
        Model instances seen.
    candidate_indices : numpy.ndarray
        Sorted int64 indices of the candidate models (instances not falsified).
    n_candidates : int
        Size of the candidate model set.
    model_class_falsified : bool
        True iff every instance is falsified, so the model class is (Sec. 3.1).
    candidate_mask : numpy.ndarray
        Boolean (N,), True at the candidates.
    per_sensor_falsified : numpy.ndarray or None
        int64 (n_m): instances each sensor rejects. ``None`` with ``diagnostics=False``.
    falsified_only_by : numpy.ndarray or None
        int64 (n_m): instances rejected by that sensor and by no other, so
        ``n_candidates + falsified_only_by[i]`` is the candidate set size when
        sensor i is left out. ``None`` with ``diagnostics=False``.
    candidates_without_sensor : numpy.ndarray or None
        Candidate set size when each sensor in turn is left out.
    n_invalid : int or None
        Instances with a NaN prediction (never candidates). ``None`` with
        ``diagnostics=False``.
    n_violated : numpy.ndarray or None
        int32 (N): sensors each instance violates, when kept.
    candidate_parameters, candidate_predictions : numpy.ndarray or None
        Parameters (n_c, p) and predictions (n_c, n_m) of the candidates, when
        the instances came from `falsify_model`.

    Examples
    --------
    >>> import edmf_rs
    >>> thresholds = edmf_rs.Thresholds(low=[-1.0, -1.0], high=[1.0, 1.0])
    >>> r = edmf_rs.falsify([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0]], [0.0, 0.0], thresholds, progress=False)
    >>> r
    FalsificationResult(n_instances=3, n_candidates=1, model_class_falsified=False)
    >>> r.candidate_mask.tolist(), r.candidates_without_sensor.tolist()
    ([True, False, False], [2, 1])
    >>> print(r.summary())
    EDMF: 3 model instances, 2 sensors
    candidate model set: 1 instances (33.3 %)
    sensors falsifying most instances: #0 (2), #1 (1)
    """

    thresholds: Thresholds
    measurements: np.ndarray
    n_instances: int
    # Given an array or the accumulator's `CandidateSegments` (derived on first read).
    candidate_indices: np.ndarray = LazyIndices()
    per_sensor_falsified: np.ndarray | None = None
    falsified_only_by: np.ndarray | None = None
    n_invalid: int | None = None
    n_violated: np.ndarray | None = None
    candidate_parameters: np.ndarray | None = None
    candidate_predictions: np.ndarray | None = None

    @property
    def n_sensors(self) -> int:
        return self.thresholds.n_sensors

    @property
    def n_candidates(self) -> int:
        raw = LazyIndices.raw(self)
        return raw.count if isinstance(raw, CandidateSegments) else int(raw.shape[0])

    @property
    def model_class_falsified(self) -> bool:
        """True iff every instance is falsified: the model class itself is (Sec. 3.1)."""
        return self.n_candidates == 0

    @cached_property
    def candidate_mask(self) -> np.ndarray:
        raw = LazyIndices.raw(self)
        if isinstance(raw, CandidateSegments):
            return raw.mask(self.n_instances)  # from the bits, without forming the indices
        mask = np.zeros(self.n_instances, dtype=bool)
        mask[self.candidate_indices] = True
        mask.flags.writeable = False
        return mask

    @property
    def candidates_without_sensor(self) -> np.ndarray | None:
        """Candidate set size when each sensor in turn is ignored (leave-one-out)."""
        if self.falsified_only_by is None:
            return None
        return self.n_candidates + self.falsified_only_by

    def summary(self) -> str:
        """A few lines for the terminal: instances, thresholds, candidates, sensors that falsify most.

        Returns
        -------
        str
            The summary; when the model class is falsified, it names the sensor
            whose removal alone would leave the most candidates.

        Examples
        --------
        >>> import edmf_rs
        >>> t = edmf_rs.Thresholds(low=[-1.0, -1.0], high=[1.0, 1.0])
        >>> r = edmf_rs.falsify([[5.0, 0.0], [5.0, 0.5]], [0.0, 0.0], t, progress=False)
        >>> print(r.summary())
        EDMF: 2 model instances, 2 sensors
        candidate model set: EMPTY - every instance is falsified, so the model class is falsified
        sensors falsifying most instances: #0 (2), #1 (0)
        ignoring sensor #0 alone would leave 2 candidates: check it for an outlier
        """
        t = self.thresholds
        share = 100.0 * self.n_candidates / self.n_instances if self.n_instances else 0.0
        lines = [
            f"EDMF: {self.n_instances:,} model instances, {self.n_sensors} sensors",
        ]
        if t.phi is not None:
            lines.append(
                f"thresholds: phi = {t.phi:g}, {t.correction} correction, per-sensor probability {t.probability:.6f}"
            )
        if self.n_instances == 0:
            lines.append("candidate model set: EMPTY - no model instance was given")
        elif self.model_class_falsified:
            lines.append("candidate model set: EMPTY - every instance is falsified, so the model class is falsified")
        else:
            lines.append(f"candidate model set: {self.n_candidates:,} instances ({share:.3g} %)")
        if self.n_invalid:
            lines.append(f"invalid instances (NaN predictions): {self.n_invalid:,}")
        if self.per_sensor_falsified is not None and self.n_instances:
            order = np.argsort(-self.per_sensor_falsified, kind="stable")[:5]
            top = ", ".join(f"#{i} ({self.per_sensor_falsified[i]:,})" for i in order)
            lines.append(f"sensors falsifying most instances: {top}")
            lone = self.candidates_without_sensor
            if self.model_class_falsified and lone.max() > 0:
                i = int(np.argmax(lone))
                lines.append(
                    f"ignoring sensor #{i} alone would leave {lone[i]:,} candidates: check it for an outlier"
                )
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (f"FalsificationResult(n_instances={self.n_instances}, n_candidates={self.n_candidates}, "
                f"model_class_falsified={self.model_class_falsified})")


def concatenate(parts: list[FalsificationResult]) -> FalsificationResult:
    """One result for consecutive blocks of instances, given in instance order.

    Counts add up and candidate indices are shifted by the instances before
    each block, so the outcome equals falsifying all instances at once (this
    is how `edmf_rs.dask` merges its blocks).

    Parameters
    ----------
    parts : list of FalsificationResult
        Results of consecutive blocks, against the same thresholds and
        measurements.

    Returns
    -------
    FalsificationResult
        The result over all the blocks.

    Raises
    ------
    ValueError
        If ``parts`` is empty or its results were computed against other
        thresholds or measurements.

    Examples
    --------
    >>> import numpy as np
    >>> import edmf_rs
    >>> t = edmf_rs.Thresholds(low=[-1.0], high=[1.0])
    >>> P = np.array([[0.0], [5.0], [0.5], [-3.0], [1.0]])
    >>> parts = [edmf_rs.falsify(P[:2], [0.0], t, progress=False),
    ...          edmf_rs.falsify(P[2:], [0.0], t, progress=False)]
    >>> whole = edmf_rs.concatenate(parts)
    >>> whole.candidate_indices.tolist(), whole.n_instances
    ([0, 2, 4], 5)
    """
    if not parts:
        raise ValueError("parts: expected at least one result")
    first = parts[0]
    for k, p in enumerate(parts):
        if p.n_sensors != first.n_sensors or not (
            np.array_equal(p.thresholds.low, first.thresholds.low)
            and np.array_equal(p.thresholds.high, first.thresholds.high)
            and np.array_equal(p.measurements, first.measurements)
        ):
            raise ValueError(f"parts: result {k} was computed against other thresholds or measurements")
    offsets = np.cumsum([0] + [p.n_instances for p in parts[:-1]])

    def total(field):
        values = [getattr(p, field) for p in parts]
        return None if any(v is None for v in values) else sum(values[1:], values[0])

    def stacked(field, shift=False):
        values = [getattr(p, field) for p in parts]
        if any(v is None for v in values):
            return None
        if shift:
            values = [v + off for v, off in zip(values, offsets)]
        # Empty parts (e.g. an empty batch, whose dtype nobody chose) do not decide the dtype.
        return np.concatenate([v for v in values if len(v)] or values)

    return FalsificationResult(
        thresholds=first.thresholds,
        measurements=first.measurements,
        n_instances=int(sum(p.n_instances for p in parts)),
        candidate_indices=stacked("candidate_indices", shift=True).astype(np.int64),
        per_sensor_falsified=total("per_sensor_falsified"),
        falsified_only_by=total("falsified_only_by"),
        n_invalid=total("n_invalid"),
        n_violated=stacked("n_violated"),
        candidate_parameters=stacked("candidate_parameters"),
        candidate_predictions=stacked("candidate_predictions"),
    )
