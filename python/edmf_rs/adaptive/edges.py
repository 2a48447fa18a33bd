"""The edges of the kept region (issue 16): where the candidate ranges are decided.

The candidate set's per-parameter ranges are set by its extreme members. The
screening sample resolves the kept region's edges only to its spacing, and
space-filling runs reach them slowly; so each adaptive and the final wave run
the model at points moved, on the emulator's mean, to the extreme of each
parameter over the region where that mean passes Eq. 8. The emulator only
proposes these points: the real runs decide whether they are candidates.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def push(points: np.ndarray, axes: np.ndarray, signs: np.ndarray, passes: Callable, steps: int = 24) -> np.ndarray:
    """Moves each point along its axis (direction ``sign``) as far as ``passes``
    stays true, by bisection between where it holds (the start) and the
    domain's edge; returns the last passing positions.

    Parameters
    ----------
    points
        (n, p) start points in the unit cube, where ``passes`` holds.
    axes, signs
        Per point, the parameter to move along and the direction (-1 or +1).
    passes
        (m, p) points -> (m,) booleans (e.g. Eq. 8 on the emulator's mean).
    steps
        Bisection steps (the position is resolved to 2^-steps of the room).

    Returns
    -------
    numpy.ndarray
        (n, p) pushed points (a start where ``passes`` fails stays put unless
        it holds at the domain's edge).

    Raises
    ------
    IndexError
        ``axes`` out of range.

    Examples
    --------
    >>> inside = lambda u: u.sum(axis=1) <= 1.0
    >>> push(np.array([[0.2, 0.3]]), np.array([0]), np.array([1.0]), inside).round(6).tolist()
    [[0.7, 0.3]]
    """
    rows = np.arange(points.shape[0])
    room = np.where(signs > 0, 1.0 - points[rows, axes], points[rows, axes])
    good, bad = np.zeros(len(rows)), room.copy()

    def moved(t):
        out = points.copy()
        out[rows, axes] += signs * t
        return np.clip(out, 0.0, 1.0)

    at_edge = passes(moved(room))
    good[at_edge] = room[at_edge]
    for _ in range(steps):
        mid = 0.5 * (good + bad)
        ok = passes(moved(mid)) & ~at_edge
        good = np.where(ok, mid, good)
        bad = np.where(ok | at_edge, bad, mid)
    return moved(good)


def walk(points: np.ndarray, axes: np.ndarray, signs: np.ndarray, passes: Callable,
         deltas: tuple[float, ...] = (0.2, 0.1, 0.05, 0.02, 0.01), offsets: int = 41, rounds: int = 8) -> np.ndarray:
    """The extreme of each point's parameter (``axes``, direction ``signs``)
    over the region where ``passes`` holds, by a pattern search.

    Each point is pushed along its parameter (:func:`push`). Then, for each
    step in ``deltas`` and up to ``rounds`` times while it gains: move the
    point sideways by the step along every other parameter, both ways; along
    its own parameter take the farthest-out position (of ``offsets`` positions
    within half the domain either way) where ``passes`` holds; push from the
    best such position and keep it if the parameter went further out. A thin,
    slanted kept region reaches its extreme in one parameter at a corner (e.g.
    another parameter at its bound) that an axis push from a screening point
    does not reach; the candidate ranges are decided there. Deterministic;
    each round is one batched call of ``passes`` and one push.

    Parameters
    ----------
    points, axes, signs, passes
        As for :func:`push`.
    deltas
        Sideways step lengths, largest first.
    offsets
        Positions tried along the point's own parameter after a sideways move.
    rounds
        Most moves per step length.

    Returns
    -------
    numpy.ndarray
        (n, p) points where ``passes`` holds, each at least as far out in its
        parameter as :func:`push` reaches.

    Raises
    ------
    IndexError
        ``axes`` out of range.

    Examples
    --------
    >>> band = lambda u: np.abs(u[:, 0] - 0.5 * u[:, 1] - 0.3) <= 0.01   # thin, slanted
    >>> start = np.array([[0.45, 0.3]])
    >>> push(start, np.array([0]), np.array([-1.0]), band).round(3).tolist()   # stays at u1 = 0.3
    [[0.44, 0.3]]
    >>> walk(start, np.array([0]), np.array([-1.0]), band).round(3).tolist()   # the corner u1 = 0
    [[0.29, 0.0]]
    """
    n, p = points.shape
    rows = np.arange(n)
    best = push(points, axes, signs, passes)
    score = signs * best[rows, axes]
    shifts = np.linspace(-0.5, 0.5, offsets)
    moves = [(k, d) for k in range(p) for d in (-1.0, 1.0)]
    for delta in deltas:
        for _ in range(rounds):
            # tries[m, o, i]: point i moved by move m sideways and by shift o along its parameter
            tries = np.repeat(np.repeat(best[None, None], len(moves), axis=0), shifts.size, axis=1)
            for m, (k, d) in enumerate(moves):
                tries[m, :, :, k] += d * delta
            tries[:, :, rows, axes] += shifts[None, :, None]
            tries = np.clip(tries, 0.0, 1.0)
            ok = passes(tries.reshape(-1, p)).reshape(len(moves), shifts.size, n)
            ok &= np.array([k for k, _ in moves])[:, None, None] != axes[None, None, :]
            reach = np.where(ok, signs[None, None, :] * tries[:, :, rows, axes], -np.inf)
            flat = reach.reshape(-1, n)
            pick = flat.argmax(axis=0)
            found = np.isfinite(flat[pick, rows])
            if not found.any():
                break
            start = tries.reshape(-1, n, p)[pick, rows]
            pushed = push(start[found], axes[found], signs[found], passes)
            gain = signs[found] * pushed[np.arange(found.sum()), axes[found]] > score[found] + 1e-9
            if not gain.any():
                break
            sel = np.flatnonzero(found)[gain]
            best[sel] = pushed[gain]
            score = signs * best[rows, axes]
    return best
