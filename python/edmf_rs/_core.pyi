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
def set_num_threads(n: int) -> None: ...
def get_num_threads() -> int: ...

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
    def take_candidates(self) -> npt.NDArray[np.uint64]: ...
    def candidates(self, start: int = 0) -> npt.NDArray[np.uint64]: ...
    def tally(self) -> tuple[npt.NDArray[np.uint64], npt.NDArray[np.uint64], int] | None: ...
    def take_violations(self) -> npt.NDArray[np.uint32] | None: ...

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
