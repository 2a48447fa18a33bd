"""Type stubs for the Rust extension (see rust/bindings)."""

import numpy as np
import numpy.typing as npt

def shortest_intervals(
    samples: npt.NDArray[np.float64], probability: float
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def min_samples(probability: float) -> int: ...
def mahalanobis_squared(
    points: npt.NDArray[np.float64], mean: npt.NDArray[np.float64], covariance: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]: ...
def set_num_threads(n: int) -> None:
    """Sets how many threads edmf_rs uses from now on.

    The package runs its Rust work (falsification, shortest intervals) on a
    pool of its own, sized by this call, else by the environment variable
    ``EDMF_RS_NUM_THREADS``, else by the number of cores. Results do not
    depend on the thread count.

    Parameters
    ----------
    n : int
        Number of threads, at least 1.

    Returns
    -------
    None

    Raises
    ------
    ValueError
        If ``n`` is less than 1.
    RuntimeError
        If the operating system cannot start the threads.

    Examples
    --------
    >>> import edmf_rs
    >>> before = edmf_rs.get_num_threads()
    >>> edmf_rs.set_num_threads(1)
    >>> edmf_rs.get_num_threads()
    1
    >>> edmf_rs.set_num_threads(before)
    """
def prefetch() -> str:
    """The prefetch of the AVX-512 short-row kernels (rows of up to two
    vectors, and back-to-back rows whose pattern repeats within eight):
    ``"nta:4096"`` (non-temporal, 4 KiB ahead), ``"t1:8192"`` (into L2, 8 KiB
    ahead), ... or ``"off"``. Chosen for this CPU, or named by the environment
    variable ``EDMF_RS_PREFETCH``. (The other kernels always use
    ``"t1:6144"``, into L2 6 KiB ahead.)"""

def set_prefetch(name: str) -> None:
    """Uses the prefetch ``name`` (as `prefetch` gives it) from now on, to
    compare them side by side; the candidates do not depend on it. A name it
    cannot read raises ``ValueError``."""

def get_num_threads() -> int:
    """How many threads edmf_rs uses.

    Starts the pool on first use (see ``set_num_threads``).

    Returns
    -------
    int
        The number of threads of edmf_rs's own pool.

    Raises
    ------
    ValueError
        If ``EDMF_RS_NUM_THREADS`` is set to something other than a positive
        integer (and ``set_num_threads`` was not called).

    Examples
    --------
    >>> import edmf_rs
    >>> edmf_rs.get_num_threads() >= 1
    True
    """

class Falsifier:
    def __init__(
        self,
        measurements: npt.NDArray[np.float64],
        low: npt.NDArray[np.float64],
        high: npt.NDArray[np.float64],
        *,
        diagnostics: bool = True,
        keep_violations: bool = True,
    ) -> None: ...
    def update(self, chunk: npt.NDArray[np.float64] | npt.NDArray[np.float32]) -> None: ...
    @property
    def n_instances(self) -> int: ...
    @property
    def n_sensors(self) -> int: ...
    @property
    def n_candidates(self) -> int: ...
    def take_candidate_segments(
        self,
    ) -> list[npt.NDArray[np.uint64] | tuple[int, int, npt.NDArray[np.uint64]]]: ...
    def candidate_bitmap(self, since: int, rows: int) -> npt.NDArray[np.uint64]: ...
    def candidates_since(self, since: int = 0) -> npt.NDArray[np.uint64]: ...
    def tally(self) -> tuple[npt.NDArray[np.uint64], npt.NDArray[np.uint64], int] | None: ...
    def take_violations(self) -> npt.NDArray[np.uint32] | None: ...

def screen_emulator(
    mu: npt.NDArray[np.float64],
    sigma: npt.NDArray[np.float64],
    measurements: npt.NDArray[np.float64],
    low: npt.NDArray[np.float64],
    high: npt.NDArray[np.float64],
    c: float,
) -> tuple[npt.NDArray[np.uint64], list[int]]: ...
class RowDigest:
    """Block checksums (``algorithm``, see rust/src/digest.rs) of rows fed in instance order, one per
    fixed block of instances: a guard against accidental change of the input, not tampering."""

    algorithm: str
    block_rows: int
    def __init__(self) -> None: ...
    def update(self, chunk: npt.NDArray[np.float64] | npt.NDArray[np.float32]) -> None: ...
    @property
    def n_rows(self) -> int: ...
    @property
    def n_blocks(self) -> int: ...
    def blocks(self, start: int = 0) -> list[str]: ...
    def partial(self) -> str | None: ...
# Measurement-system design (rust/bindings/src/design.rs).
def design_joint_entropy(
    predictions: npt.NDArray[np.float64] | npt.NDArray[np.float32],
    widths: npt.NDArray[np.float64],
    sensors: list[int],
    nan_bin: bool = False,
) -> float: ...
def design_place(
    predictions: npt.NDArray[np.float64] | npt.NDArray[np.float32],
    widths: npt.NDArray[np.float64],
    k: int,
    fixed: list[int],
    costs: npt.NDArray[np.float64] | None = None,
    budget: float | None = None,
    tolerance: float | None = None,
    nan_bin: bool = False,
) -> tuple[npt.NDArray[np.uint64], npt.NDArray[np.float64], int]: ...
def design_candidate_counts(
    predictions: npt.NDArray[np.float64] | npt.NDArray[np.float32],
    sensors: list[int],
    truth: npt.NDArray[np.uint64],
    residuals: npt.NDArray[np.float64],
    low: npt.NDArray[np.float64],
    high: npt.NDArray[np.float64],
) -> npt.NDArray[np.uint64]: ...
