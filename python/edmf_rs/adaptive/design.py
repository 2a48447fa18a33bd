"""Where to run the model next: space-filling designs in the unit cube, the
record of every real run, the points probed when the emulator keeps none, and
the least budget of a run (issue 16, steps 1 and 4)."""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial import cKDTree
from scipy.stats import qmc

#: Kept points considered by the farthest-point selection (a deterministic
#: stride through them beyond this): the selection costs O(pool x picks).
POOL = 20_000


def sobol_points(n: int, d: int, seed: int, skip: int = 0) -> np.ndarray:
    """Points ``skip .. skip + n - 1`` of a scrambled Sobol' sequence in [0, 1)^d.

    Examples
    --------
    >>> sobol_points(4, 2, seed=0).shape
    (4, 2)
    >>> bool((sobol_points(3, 2, 0, skip=1) == sobol_points(4, 2, 0)[1:]).all())
    True
    """
    try:
        engine = qmc.Sobol(d, rng=seed)
    except TypeError:  # SciPy < 1.15 names it seed
        engine = qmc.Sobol(d, seed=seed)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*balance properties.*")
        if skip:
            engine.fast_forward(skip)
        return engine.random(n)


def farthest_points(pool: np.ndarray, existing: np.ndarray, k: int, first: np.ndarray | None = None) -> np.ndarray:
    """Greedy maximin selection: ``k`` rows of ``pool``, each the farthest from
    the runs so far (``existing``) and the rows already picked.

    ``first`` are pool rows taken before the greedy picks (e.g. the kept
    region's extremes). Ties go to the lowest index, so the choice is
    deterministic. Rows at distance 0 from a run are never picked (no run is
    repeated); fewer than ``k`` rows come back when the pool runs out.

    Examples
    --------
    >>> pool = np.array([[0.0], [0.1], [0.5], [1.0]])
    >>> farthest_points(pool, np.array([[0.0]]), 2).tolist()
    [3, 2]
    """
    if pool.shape[0] > POOL:
        pool_index = np.linspace(0, pool.shape[0] - 1, POOL).round().astype(np.int64)
    else:
        pool_index = np.arange(pool.shape[0])
    candidates = pool[pool_index]
    if existing.shape[0]:
        dist = cKDTree(existing).query(candidates, k=1)[0]
    else:
        dist = np.full(candidates.shape[0], np.inf)
    picked: list[int] = []
    forced = [] if first is None else [int(i) for i in first]
    for i in forced:
        where = np.flatnonzero(pool_index == i)
        position = where[0] if where.size else None
        if position is None:  # an extreme outside the strided pool: add it
            candidates = np.vstack([candidates, pool[i]])
            pool_index = np.append(pool_index, i)
            row = pool[i]
            d = cKDTree(existing).query(row[None], k=1)[0][0] if existing.shape[0] else np.inf
            dist = np.append(dist, d)
            position = candidates.shape[0] - 1
        if dist[position] > 0 and len(picked) < k:
            picked.append(position)
            dist = np.minimum(dist, np.linalg.norm(candidates - candidates[position], axis=1))
    while len(picked) < k:
        j = int(np.argmax(dist))
        if not dist[j] > 0:
            break
        picked.append(j)
        dist = np.minimum(dist, np.linalg.norm(candidates - candidates[j], axis=1))
    return pool_index[np.array(picked, dtype=np.int64)]


def extremes(points: np.ndarray) -> np.ndarray:
    """Indices of the rows with the smallest and largest value of each column
    (the ends of each parameter's range), without repeats."""
    if points.shape[0] == 0:
        return np.empty(0, np.int64)
    ends = np.concatenate([points.argmin(axis=0), points.argmax(axis=0)])
    return np.unique(ends)


def edge_rows(points: np.ndarray, n_per_end: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``n_per_end`` rows with the smallest values of each column, then the
    ``n_per_end`` with the largest, as (rows, column, sign): sign -1 at a low
    end, +1 at a high end. A row may appear for several columns. Ties go to the
    lowest index (stable sort): deterministic. See :func:`edge_points`.

    Parameters
    ----------
    points
        (n, p) points.
    n_per_end
        Rows taken at each end of each column (at least 1).

    Returns
    -------
    tuple of numpy.ndarray
        Row indices, their column, their sign; ``2 * p * min(n_per_end, n)`` each.

    Raises
    ------
    ValueError
        ``n_per_end`` below 1 or ``points`` not 2-D.

    Examples
    --------
    >>> rows, cols, signs = edge_rows(np.array([[0.1, 0.9], [0.5, 0.2]]), 1)
    >>> rows.tolist(), cols.tolist(), signs.tolist()
    ([0, 1, 1, 0], [0, 1, 0, 1], [-1.0, -1.0, 1.0, 1.0])
    """
    if points.ndim != 2:
        raise ValueError(f"points: expected a 2-D array, got {points.ndim} dimensions")
    if isinstance(n_per_end, bool) or int(n_per_end) != n_per_end or n_per_end < 1:
        raise ValueError(f"n_per_end: expected an integer >= 1, got {n_per_end!r}")
    n, p = min(int(n_per_end), points.shape[0]), points.shape[1]
    lows = np.argsort(points, axis=0, kind="stable")[:n].T.reshape(-1)
    highs = np.argsort(-points, axis=0, kind="stable")[:n].T.reshape(-1)
    cols = np.repeat(np.arange(p), n)
    return (np.concatenate([lows, highs]).astype(np.int64), np.concatenate([cols, cols]),
            np.concatenate([-np.ones(p * n), np.ones(p * n)]))


def edge_points(points: np.ndarray, n_per_end: int) -> np.ndarray:
    """Indices of the rows with the ``n_per_end`` smallest and the
    ``n_per_end`` largest values of each column, without repeats (first
    occurrence kept, in the order of :func:`edge_rows`: every column's lows,
    then every column's highs).

    These are the kept points at the edges of each parameter's range, where the
    candidate ranges are decided: a thin kept region reaches its extreme in one
    parameter at a corner that a single extreme point, or space-filling alone,
    finds slowly.

    Parameters
    ----------
    points
        (n, p) points (e.g. the kept screening points, unit cube).
    n_per_end
        How many points to take at each end of each column (at least 1).

    Returns
    -------
    numpy.ndarray
        Row indices (int64).

    Raises
    ------
    ValueError
        ``n_per_end`` below 1 or ``points`` not 2-D.

    Examples
    --------
    >>> pts = np.array([[0.5, 0.0], [0.1, 0.9], [0.9, 0.5], [0.2, 0.4]])
    >>> edge_points(pts, 1).tolist()
    [1, 0, 2]
    >>> edge_points(pts, 2).tolist()
    [1, 3, 0, 2]
    """
    rows = edge_rows(points, n_per_end)[0]
    _, first = np.unique(rows, return_index=True)
    return rows[np.sort(first)]


class RunStore:
    """Every real model run: parameters (unit cube and domain), outputs, and
    the wave that asked for it. A parameter row already run is never run
    again: its stored outputs are returned."""

    def __init__(self, n_params: int, n_sensors: int):
        self.u = np.empty((0, n_params))
        self.theta = np.empty((0, n_params))
        self.g = np.empty((0, n_sensors))
        self.wave = np.empty(0, np.int64)
        self._index: dict[bytes, int] = {}

    @property
    def n_runs(self) -> int:
        return int(self.theta.shape[0])

    def new_rows(self, theta: np.ndarray) -> np.ndarray:
        """Indices of the rows of ``theta`` not run yet (first occurrence only)."""
        seen, keep = set(), []
        for i, row in enumerate(np.ascontiguousarray(theta, dtype=np.float64)):
            key = row.tobytes()
            if key not in self._index and key not in seen:
                seen.add(key)
                keep.append(i)
        return np.array(keep, dtype=np.int64)

    def add(self, u: np.ndarray, theta: np.ndarray, g: np.ndarray, wave: int) -> None:
        for i, row in enumerate(np.ascontiguousarray(theta, dtype=np.float64)):
            self._index[row.tobytes()] = self.n_runs + i
        self.u = np.vstack([self.u, u])
        self.theta = np.vstack([self.theta, theta])
        self.g = np.vstack([self.g, g])
        self.wave = np.concatenate([self.wave, np.full(theta.shape[0], wave, np.int64)])


#: What to change when :func:`budget_problem` finds the budget too small.
BUDGET_HINT = "raise budget or lower n_initial or wave_size"


def budget_problem(p: int, budget: int, n_initial: int | None = None, wave_size: int | None = None) -> str | None:
    """What ``budget`` must be, when it cannot hold the initial design and one
    wave (``n_initial`` and ``wave_size`` None: their defaults for ``p``
    parameters, 20 x p and 10 x p); None when it can. The rule of
    :func:`adaptive_falsify` and of an adaptive project's ``budget``.

    Examples
    --------
    >>> budget_problem(1, 20)
    'at least n_initial + wave_size = 20 + 10 = 30 real runs (the initial design and one wave)'
    >>> budget_problem(1, 30) is None
    True
    """
    n_initial = 20 * p if n_initial is None else n_initial
    wave_size = 10 * p if wave_size is None else wave_size
    if budget >= n_initial + wave_size:
        return None
    return (f"at least n_initial + wave_size = {n_initial} + {wave_size} = {n_initial + wave_size} real runs "
            "(the initial design and one wave)")


def pool_size(k: int) -> int:
    """Screening points the next wave of ``k`` runs is drawn from when none is kept.

    Examples
    --------
    >>> pool_size(10), pool_size(100)
    (1000, 2000)
    """
    return max(20 * k, 1000)


def closest(screening: np.ndarray, nearest: tuple[np.ndarray, np.ndarray], runs: np.ndarray,
            k: int) -> np.ndarray:
    """k points spread over the screening points the emulator deems least
    inconsistent, when it keeps none: ``nearest`` holds screening points
    (indices) and the margin c each needs with the emulator's exact deviation;
    the ``pool_size(k)`` that need the smallest margin are where a candidate
    would be if the emulator were wrong, and the k picked among them are
    those farthest from the runs (:func:`farthest_points`).

    Examples
    --------
    Point 1 is not among those checked; of the others, 3 is the farthest from the run at 0:

    >>> screening = np.array([[0.1], [0.95], [0.5], [0.9]])
    >>> closest(screening, (np.array([0, 2, 3]), np.array([4.0, 5.0, 90.0])), np.array([[0.0]]), 1).tolist()
    [[0.9]]
    """
    pool, need = nearest
    order = pool[np.sort(np.argsort(need, kind="stable")[:pool_size(k)])]
    picked = farthest_points(screening[order], runs, k)
    return screening[order[picked]]
