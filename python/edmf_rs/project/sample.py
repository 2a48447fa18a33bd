"""A deterministic sample of every instance for the plots: every k-th one.

Falsified instances are not kept by the falsification, so the plots draw the
falsified ones from this sample. Its memory is bounded (``PLOT_SAMPLE`` rows
whatever N), and so is what it needs to tell which sampled instances are
candidates: the candidates' indices are offered batch by batch
(`PlotSample.mark`) and only those in the sample are kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Instances kept for the plots; falsified ones are drawn from this sample.
PLOT_SAMPLE = 3000


@dataclass(frozen=True, eq=False)
class InstanceSample:
    """Every k-th instance: index, parameters, predictions and whether it is a candidate."""

    index: np.ndarray
    parameters: np.ndarray
    predictions: np.ndarray
    is_candidate: np.ndarray


class PlotSample:
    """Every k-th instance (k = ceil(N / limit)), as it streams past (``on_batch``).

    Examples
    --------
    >>> s = PlotSample(10, limit=5)
    >>> s(0, np.arange(10.0)[:, None], np.zeros((10, 1)))
    >>> s.mark(np.array([1, 2, 3]))
    >>> s.finish().index.tolist(), s.finish().is_candidate.tolist()
    ([0, 2, 4, 6, 8], [False, True, False, False, False])
    """

    def __init__(self, n_instances: int, limit: int = PLOT_SAMPLE):
        self.stride = max(1, math.ceil(n_instances / limit))
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.marked: list[np.ndarray] = []

    def __call__(self, offset: int, parameters: np.ndarray, predictions: np.ndarray) -> None:
        first = (-offset) % self.stride  # the next multiple of stride at or after offset
        # copies: a view would keep the whole batch alive
        self.parts.append((np.arange(offset + first, offset + parameters.shape[0], self.stride),
                           parameters[first::self.stride].copy(),
                           np.array(predictions[first::self.stride], dtype=np.float64)))

    def mark(self, candidate_indices: np.ndarray) -> None:
        """Candidates found (instance indices): those in the sample are remembered."""
        hit = candidate_indices[np.asarray(candidate_indices) % self.stride == 0]
        if hit.size:
            self.marked.append(np.asarray(hit, dtype=np.int64))

    def finish(self, candidate_mask: np.ndarray | None = None) -> InstanceSample:
        """The sample; which instances are candidates comes from ``candidate_mask`` (N,) when
        given, else from the indices passed to `mark`."""
        if not self.parts:
            return InstanceSample(np.empty(0, np.int64), np.empty((0, 0)), np.empty((0, 0)), np.empty(0, bool))
        index, theta, predictions = (np.concatenate(x) for x in zip(*self.parts))
        if candidate_mask is not None:
            is_candidate = candidate_mask[index]
        else:
            is_candidate = np.isin(index, np.concatenate(self.marked) if self.marked else np.empty(0, np.int64))
        return InstanceSample(index, theta, predictions, is_candidate)
