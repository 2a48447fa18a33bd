"""Plain NumPy/SciPy EDMF, written for clarity rather than speed.

This is the oracle the Rust core is tested against: every function here
follows the paper's equations line by line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .engine.result import FalsificationResult
from .engine.thresholds import Thresholds


def sensor_probability(phi: float, n_sensors: int, correction: str = "sidak") -> float:
    """Per-sensor probability for a joint target ``phi`` (Eq. 5 with Sidak; Bonferroni; none).

    Parameters
    ----------
    phi : float
        Target identification probability, in (0, 1).
    n_sensors : int
        Number of sensors n_m.
    correction : {"sidak", "bonferroni", "none"}, default "sidak"
        ``phi**(1/n_m)``, ``1 - (1 - phi)/n_m`` or ``phi``.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        If ``phi`` is not in (0, 1).
    KeyError
        If ``correction`` is unknown.

    Examples
    --------
    >>> from edmf_rs import reference
    >>> round(reference.sensor_probability(0.95, 2), 6)
    0.974679
    """
    if not 0.0 < phi < 1.0:
        raise ValueError(f"phi: expected a value in (0, 1), got {phi}")
    return {
        "sidak": lambda: phi ** (1.0 / n_sensors),  # Eq. 5
        "bonferroni": lambda: 1.0 - (1.0 - phi) / n_sensors,
        "none": lambda: phi,
    }[correction]()


def shortest_interval(samples: np.ndarray, probability: float) -> tuple[float, float]:
    """Shortest interval holding ceil(p * n) of the samples (lowest one on ties; Eq. 5).

    Parameters
    ----------
    samples : array_like
        Monte Carlo samples of one sensor's U_c.
    probability : float
        Probability the interval holds, in (0, 1).

    Returns
    -------
    tuple of float
        ``(low, high)``, both sample values.

    Raises
    ------
    ValueError
        If there are fewer than ``ceil(1 / (1 - probability))`` samples.

    Examples
    --------
    >>> from edmf_rs import reference
    >>> reference.shortest_interval([0.0, 1.0, 1.5, 2.0, 9.0], 0.6)
    (1.0, 2.0)
    """
    x = np.sort(np.asarray(samples, dtype=np.float64))
    n = x.size
    if n < math.ceil(1.0 / (1.0 - probability)):
        raise ValueError(f"combined: too few samples ({n}) for probability {probability}")
    k = min(max(math.ceil(probability * n), 1), n)
    widths = x[k - 1:] - x[: n - k + 1]
    i = int(np.argmin(widths))
    return float(x[i]), float(x[i + k - 1])


def shortest_interval_of(dist, probability: float, grid: int = 20001) -> tuple[float, float]:
    """Shortest interval of a frozen distribution by brute force over the lower tail mass (Eq. 5).

    Parameters
    ----------
    dist : scipy.stats frozen distribution
        Scalar continuous distribution of one sensor's U_c.
    probability : float
        Probability the interval holds.
    grid : int, default 20001
        Points of the grid over the lower tail mass.

    Returns
    -------
    tuple of float
        ``(low, high)``.

    Raises
    ------
    ValueError
        If every width is NaN (a distribution whose ``ppf`` is undefined).

    Examples
    --------
    >>> from scipy import stats
    >>> from edmf_rs import reference
    >>> low, high = reference.shortest_interval_of(stats.norm(0, 1), 0.95)
    >>> round(low, 3), round(high, 3)
    (-1.96, 1.96)
    """
    a = np.linspace(0.0, 1.0 - probability, grid)[1:-1]
    widths = dist.ppf(a + probability) - dist.ppf(a)
    i = int(np.nanargmin(widths))
    return float(dist.ppf(a[i])), float(dist.ppf(a[i] + probability))


def threshold_bounds(combined, phi: float = 0.95, correction: str = "sidak") -> Thresholds:
    """Eq. 5 per sensor, from samples (n_samples, n_m) or a list of frozen distributions.

    Parameters
    ----------
    combined : array_like or list of scipy.stats frozen distributions
        Monte Carlo samples of U_c (n_samples, n_m), or one scalar frozen
        distribution per sensor.
    phi : float, default 0.95
        Target identification probability.
    correction : {"sidak", "bonferroni", "none"}, default "sidak"
        See `sensor_probability`.

    Returns
    -------
    Thresholds

    Raises
    ------
    ValueError
        If ``phi`` is out of range or there are too few samples.

    Examples
    --------
    >>> from scipy import stats
    >>> from edmf_rs import reference
    >>> t = reference.threshold_bounds([stats.norm(0, 1)], phi=0.95)
    >>> t.high.round(3).tolist()
    [1.96]
    """
    if isinstance(combined, (list, tuple)) and combined and hasattr(combined[0], "ppf"):
        p = sensor_probability(phi, len(combined), correction)
        bounds = [shortest_interval_of(d, p) for d in combined]
    else:
        samples = np.asarray(combined, dtype=np.float64)
        p = sensor_probability(phi, samples.shape[1], correction)
        bounds = [shortest_interval(samples[:, j], p) for j in range(samples.shape[1])]
    low, high = np.array(bounds).T
    return Thresholds(low, high, phi=phi, probability=p, correction=correction)


def falsify(predictions, measurements, thresholds: Thresholds) -> FalsificationResult:
    """Eq. 8 for every instance at once: ``low <= g - y <= high`` at every sensor.

    The same outputs as `edmf_rs.falsify` with diagnostics (and
    ``keep_violations``), from one NumPy expression over the whole array.

    Parameters
    ----------
    predictions : array_like
        Predictions g(theta), (N, n_m).
    measurements : array_like
        Measured values y, (n_m,).
    thresholds : Thresholds
        The threshold bounds.

    Returns
    -------
    FalsificationResult

    Raises
    ------
    ValueError
        If the shapes do not broadcast.

    Examples
    --------
    >>> import edmf_rs
    >>> from edmf_rs import reference
    >>> t = edmf_rs.Thresholds(low=[-1.0, -1.0], high=[1.0, 1.0])
    >>> r = reference.falsify([[0.5, 0.0], [2.0, 0.0], [0.0, -1.5]], [0.0, 0.0], t)
    >>> r.candidate_indices.tolist(), r.n_violated.tolist()
    ([0], [0, 1, 1])
    """
    g = np.asarray(predictions).astype(np.float64)
    y = np.asarray(measurements, dtype=np.float64)
    residuals = g - y  # Eq. 14
    inside = (thresholds.low <= residuals) & (residuals <= thresholds.high)
    violated = ~inside
    n_violated = violated.sum(axis=1)
    return FalsificationResult(
        thresholds=thresholds,
        measurements=y,
        n_instances=g.shape[0],
        candidate_indices=np.flatnonzero(inside.all(axis=1)).astype(np.int64),
        per_sensor_falsified=violated.sum(axis=0).astype(np.int64),
        falsified_only_by=violated[n_violated == 1].sum(axis=0).astype(np.int64),
        n_invalid=int(np.isnan(g).any(axis=1).sum()),
        n_violated=n_violated.astype(np.int32),
    )
# Measurement-system design (joint entropy, greedy placement, expected identifiability):
#: The checkpoint's block checksum (``rust/src/digest.rs``): lanes, block size, constants.
CHECKSUM_LANES = 8
CHECKSUM_BLOCK_ROWS = 65_536
_M64 = (1 << 64) - 1
_TAG = int.from_bytes(b"fl64x8/2", "little")


@dataclass(frozen=True)
class RowChecksums:
    """Block checksums of rows (see `row_checksums`).

    Attributes
    ----------
    blocks : tuple of str
        32-hex checksum of each complete block (block k: instances k*65536 ..).
    partial : str or None
        Checksum of the rows after the last complete block, None if there are none.
    n_rows : int
        Rows summed.

    Examples: see `row_checksums`.
    """

    blocks: tuple[str, ...]
    partial: str | None
    n_rows: int


def _fmix64(x: int) -> int:
    """MurmurHash3's 64-bit finaliser (a bijection of 64-bit words)."""
    x ^= x >> 33
    x = (x * 0xFF51AFD7ED558CCD) & _M64
    x ^= x >> 33
    x = (x * 0xC4CEB9FE1A85EC53) & _M64
    return x ^ (x >> 33)


def _block_checksum(block: np.ndarray, cols: int, rows: int) -> str:
    """Lane sums A, H, B, G of one block's words, mixed into 128 bits with its unit count."""
    raw = block.tobytes()  # little-endian values, row after row
    units = len(raw) // 4
    words = np.frombuffer(raw + bytes(4 * (units % 2)), dtype="<u8").astype(np.uint64)
    k = np.arange(words.size, dtype=np.uint64)
    lane, step, high = k % CHECKSUM_LANES, k // CHECKSUM_LANES, words >> np.uint64(32)
    sums = []
    for values in (words, high, step * words, step * high):  # uint64: wraps modulo 2**64
        sums += [int(values[lane == lane_].sum(dtype=np.uint64)) for lane_ in range(CHECKSUM_LANES)]
    state = [_TAG, cols, rows, units, *sums]
    forward, backward = 0x6564_6D66_5F72_7331, 0x9E37_79B9_7F4A_7C15
    for w in state:
        forward = _fmix64(forward ^ w)
    for w in reversed(state):
        backward = _fmix64(backward ^ w)
    return f"{forward:016x}{backward:016x}"


def row_checksums(rows) -> RowChecksums:
    """Block checksums of model-instance rows, as a checkpoint records them.

    The values are read as a run hands them to Rust (float32 of either byte
    order as float32, anything else as float64), and a block's bytes, row
    after row, little-endian, as 64-bit words (a float64 value is one word,
    two float32 values share one; an odd count is padded with zero bits).
    Word ``k`` of a block goes to lane ``k % 8`` at step ``j = k // 8``, and
    per lane, modulo 2**64, ``A = sum w``, ``H = sum (w >> 32)``,
    ``B = sum j w`` and ``G = sum j (w >> 32)``; the block's checksum mixes the
    width, the row count, the number of 32-bit units and these sums. A guard
    against accidental change of the input (any change of at most two words
    per lane is certain to show), not against deliberate tampering.

    Parameters
    ----------
    rows : array_like
        2-D (instances x sensors) real values; any dtype, byte order or layout
        (the same values as float32 and as float64 give different checksums).

    Returns
    -------
    RowChecksums
        The checksum of every complete block and of the partial last one.

    Raises
    ------
    ValueError
        If ``rows`` is not 2-D.

    Examples
    --------
    >>> import numpy as np
    >>> from edmf_rs import reference
    >>> got = reference.row_checksums(np.ones((3, 2)))
    >>> got.blocks, len(got.partial), got.n_rows
    ((), 32, 3)
    """
    arr = np.asarray(rows)
    if arr.ndim != 2:
        raise ValueError(f"rows: expected a 2-D array, got {arr.ndim} dimensions")
    single = arr.dtype.kind == "f" and arr.dtype.itemsize == 4
    values = np.ascontiguousarray(arr, dtype="<f4" if single else "<f8")
    n, cols = arr.shape
    sums = [_block_checksum(values[s:s + CHECKSUM_BLOCK_ROWS], cols, min(CHECKSUM_BLOCK_ROWS, n - s))
            for s in range(0, n, CHECKSUM_BLOCK_ROWS)]
    if n % CHECKSUM_BLOCK_ROWS:
        return RowChecksums(tuple(sums[:-1]), sums[-1], n)
    return RowChecksums(tuple(sums), None, n)


from .design.reference import (  # noqa: E402,F401,E501
    candidate_counts,
    draw_simulations,
    expected_identifiability,
    joint_entropy,
    place_sensors,
)
