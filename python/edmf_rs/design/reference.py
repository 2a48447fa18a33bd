"""Plain NumPy reference of measurement-system design, written for clarity.

The oracle the Rust core (``edmf_rs.design``) is tested against; each
function follows the definitions of the design issue line by line:

- bins ``b[k, i] = floor((G[k, i] - min_k G[k, i]) / w_i)`` in float64;
- joint entropy ``H(S) = -sum_t p_t log2 p_t`` over the distinct bin tuples of S
  (Papadopoulou, Raphael, Smith & Sekhar 2014, Entropy 16(9):5078, Eq. 3);
- greedy (hierarchical) placement, ties (within ``TIE`` bits) to the lowest index
  (Bertola, Papadopoulou, Vernay & Smith 2017, Sensors 17(12):2904);
- expected identifiability: simulated measurements ``y = G[j, S] - u`` (Eq. 4 of
  Goulet & Smith 2013) and the instances that pass Eq. 8 on S.
"""

from __future__ import annotations

import math

import numpy as np

#: Gains this close (bits, or bits per unit cost) to the best count as ties.
TIE = 1e-9


def bins(predictions, widths, nan_bin: bool = False) -> np.ndarray:
    """Bin of every instance at every location, as floats (NaN -> +inf, its own bin)."""
    g = np.asarray(predictions).astype(np.float64)
    w = np.asarray(widths, dtype=np.float64)
    if np.isnan(g).any() and not nan_bin:
        raise ValueError("predictions: NaN predictions")
    with np.errstate(all="ignore"):
        lowest = np.where(np.isnan(g), np.inf, g).min(axis=0)
    lowest = np.where(np.isfinite(lowest), lowest, 0.0)
    b = np.floor((g - lowest) / w)
    return np.where(np.isnan(g), np.inf, b)


def entropy_of_tuples(b: np.ndarray) -> float:
    """``-sum p log2 p`` over the distinct rows of ``b`` (0 for no columns)."""
    if b.shape[1] == 0 or b.shape[0] < 2:
        return 0.0
    _, counts = np.unique(b, axis=0, return_counts=True)
    p = np.sort(counts) / b.shape[0]
    return -math.fsum(p * np.log2(p))


def joint_entropy(predictions, widths, sensors=None, nan_bin: bool = False) -> float:
    """H(S) of the locations ``sensors`` (all locations if None)."""
    b = bins(predictions, widths, nan_bin)
    sensors = range(b.shape[1]) if sensors is None else list(sensors)
    return entropy_of_tuples(b[:, list(sensors)])


def place_sensors(predictions, widths, k, fixed=(), costs=None, budget=None, tolerance=None,
                  nan_bin: bool = False, types=None, max_per_type=None) -> tuple[list[int], list[float]]:
    """Greedy placement: (chosen locations in order, H after each one); at
    most ``max_per_type[t]`` sensors of type ``t`` (``types`` per location)."""
    b = bins(predictions, widths, nan_bin)
    n_loc = b.shape[1]
    cost = np.ones(n_loc) if costs is None else np.asarray(costs, dtype=np.float64)
    order = list(fixed)
    entropies = [entropy_of_tuples(b[:, order[: m + 1]]) for m in range(len(order))]
    spent = 0.0
    for i in order:
        spent += cost[i] if costs is not None else 0.0
    while len(order) < k:
        h = entropies[-1] if order else 0.0
        quota = max_per_type or {}
        remaining = [i for i in range(n_loc) if i not in order
                     and (budget is None or spent + cost[i] <= budget)
                     and (types is None or types[i] not in quota
                          or sum(types[j] == types[i] for j in order) < quota[types[i]])]
        if not remaining:
            break
        hs = [entropy_of_tuples(b[:, order + [i]]) for i in remaining]
        value = [(hi - h) / cost[i] for i, hi in zip(remaining, hs)]
        best = max(value)
        j = next(j for j, v in enumerate(value) if v >= best - TIE)
        if tolerance is not None and hs[j] - h < tolerance - TIE:  # within TIE: reached (a 0-bit gain at 0)
            break
        order.append(remaining[j])
        entropies.append(hs[j])
        if costs is not None:
            spent += cost[remaining[j]]
    return order, entropies


def draw_simulations(combined, n_instances: int, n_simulations: int, seed=0):
    """The random draws of the simulations: ``truth`` (n_simulations,) true
    instances and ``residuals`` (n_simulations, L), one draw of the combined
    uncertainty U_c at every location per simulation.

    Draws cover all L locations, so that the residuals of a set S are the
    columns S whatever S is: the sets along a greedy order share their draws.
    Monte Carlo U_c: one sample row per simulation (the sensors jointly).
    """
    rng = np.random.default_rng(seed)
    truth = rng.integers(0, n_instances, size=n_simulations).astype(np.uint64)
    if combined.exact:
        z = rng.standard_normal(size=(n_simulations, combined.n_sensors))
        residuals = combined.mean + combined.std * z
    else:
        rows = rng.integers(0, combined.samples.shape[0], size=n_simulations)
        residuals = np.asarray(combined.samples, dtype=np.float64)[rows]
    return truth, residuals


def candidate_counts(predictions, sensors, truth, residuals, low, high) -> np.ndarray:
    """Candidate-set size per simulation: Eq. 4 then Eq. 8 on the sensors S."""
    g = np.asarray(predictions)[:, list(sensors)].astype(np.float64)
    sizes = np.empty(len(truth), dtype=np.int64)
    for s, j in enumerate(np.asarray(truth, dtype=np.int64)):
        y = g[j] - residuals[s]  # Eq. 4
        r = g - y  # Eq. 14
        with np.errstate(invalid="ignore"):
            inside = (low <= r) & (r <= high)  # Eq. 8
        sizes[s] = int(inside.all(axis=1).sum())
    return sizes


def expected_identifiability(predictions, combined, sensors, n_simulations=1000, phi=0.95,
                             correction="sidak", seed=0) -> np.ndarray:
    """Candidate-set sizes of ``n_simulations`` simulated measurements on ``sensors``."""
    from ..engine.thresholds import sensor_probability, threshold_bounds

    sensors = list(sensors)
    g = np.asarray(predictions)
    truth, residuals = draw_simulations(combined, g.shape[0], n_simulations, seed)
    # Each sensor's bounds in the full U_c for the per-sensor probability of |S| sensors (Eq. 5).
    p = sensor_probability(phi, len(sensors), correction)
    t = threshold_bounds(combined, phi=p, correction="none")
    return candidate_counts(g, sensors, truth, residuals[:, sensors], t.low[sensors], t.high[sensors])
