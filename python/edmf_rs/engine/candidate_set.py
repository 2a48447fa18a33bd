"""The candidate model set as the Rust accumulator hands it over, with the
indices derived only when asked for.

The accumulator keeps candidates as a bitmap where they are dense (one bit
per instance) and as indices where they are sparse (see
``rust/src/candidates.rs``): with every instance a candidate, writing 8-byte
indices would cost more than falsifying rows of 5-10 sensors. A
`FalsificationResult` holds a `CandidateSegments` until ``candidate_indices``
is read; its count and mask come from the bits without forming the indices.
"""

from __future__ import annotations

import numpy as np

from ..stream.parts import count_bits, unpack_bits


class CandidateSegments:
    """Candidates of consecutive instances, as ``_core.Falsifier.take_candidate_segments`` gives them.

    Parameters
    ----------
    segments : list
        In instance order, each a uint64 array of candidate indices or a
        ``(first, rows, words)`` bitmap of instances ``first .. first + rows``
        (bit ``i % 64`` of ``words[i // 64]`` set iff instance ``first + i``
        is a candidate).

    Examples
    --------
    >>> import numpy as np
    >>> s = CandidateSegments([(0, 5, np.array([0b10011], np.uint64)), np.array([9], np.uint64)])
    >>> s.count, s.indices().tolist(), s.mask(10).nonzero()[0].tolist()
    (4, [0, 1, 4, 9], [0, 1, 4, 9])
    """

    def __init__(self, segments: list, count: int | None = None):
        self.segments = list(segments)
        # The accumulator knows its count; counting the bits again cost
        # 0.65 ms for 40 million candidates, 2 % of reading them (800 MB).
        self.count = sum(_count(s) for s in self.segments) if count is None else count

    def indices(self) -> np.ndarray:
        """Sorted int64 indices of the candidates (read-only)."""
        parts = [_indices(s) for s in self.segments]
        out = np.concatenate(parts) if len(parts) > 1 else (parts[0] if parts else np.empty(0, np.int64))
        out.flags.writeable = False
        return out

    def mask(self, n_instances: int) -> np.ndarray:
        """Boolean (n_instances,), True at the candidates (read-only)."""
        mask = np.zeros(n_instances, dtype=bool)
        for s in self.segments:
            if isinstance(s, tuple):
                first, rows, words = s
                mask[first:first + rows] = unpack_bits(rows, words)
            else:
                mask[s.view(np.int64)] = True
        mask.flags.writeable = False
        return mask

    def __reduce__(self):
        return (CandidateSegments, (self.segments,))


def _count(segment) -> int:
    if isinstance(segment, tuple):
        return count_bits(segment[2])
    return int(segment.shape[0])


def _indices(segment) -> np.ndarray:
    if isinstance(segment, tuple):
        first, rows, words = segment
        return np.flatnonzero(unpack_bits(rows, words)) + np.int64(first)
    return segment.view(np.int64)  # indices < 2**63: no copy


class LazyIndices:
    """Data descriptor for ``FalsificationResult.candidate_indices``: the
    field may be given an array or a `CandidateSegments`; read, it is always
    the sorted int64 array, derived once on first access.
    """

    def __set_name__(self, owner, name: str) -> None:
        self.slot = "_" + name

    def __get__(self, obj, owner=None):
        if obj is None:
            raise AttributeError("candidate_indices")  # a required dataclass field: no default
        value = obj.__dict__[self.slot]
        if isinstance(value, CandidateSegments):
            value = value.indices()
            obj.__dict__[self.slot] = value
        return value

    def __set__(self, obj, value) -> None:
        obj.__dict__[self.slot] = value

    @staticmethod
    def raw(obj, name: str = "candidate_indices"):
        """What the field holds now: an array, or the segments not yet turned into one."""
        return obj.__dict__["_" + name]


__all__: list[str] = []
