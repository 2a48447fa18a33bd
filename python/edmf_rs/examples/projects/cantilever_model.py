"""Model of ``cantilever.toml``: the idealised cantilever of Goulet & Smith (2013)
(Eq. 12) at the paper's n_m = 10 sensors, and the script that simulated the
shipped measurements (Eq. 13, scenario 2: rotational spring K = 12e10 N mm/rad).

Regenerate ``cantilever.csv`` with ``python cantilever_model.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from edmf_rs.examples import cantilever
from edmf_rs.stream.atomic import write_text

N_SENSORS = 10
SEED = 2013
X = cantilever.sensor_positions(N_SENSORS)  # x_i = 500 + i (3000 - 500) / 10, mm


def deflections(theta: np.ndarray) -> np.ndarray:
    """g(theta): v(x_i) for every Young's modulus E = theta[:, 0]; shape (n, 10), mm."""
    return cantilever.deflection(X, theta[:, 0])


def tip_deflection(theta: np.ndarray, force: float = 2 * cantilever.FORCE) -> np.ndarray:
    """Prognosis: the idealised tip deflection v(l) under ``force`` (N), mm."""
    return cantilever.deflection([cantilever.LENGTH], theta[:, 0])[:, 0] * (force / cantilever.FORCE)


def simulate_measurements(seed: int = SEED) -> np.ndarray:
    """y(x_i) = v*(x_i) - eps(x_i) + u_meas with E* = 70e3 MPa, K = 12e10 N mm/rad (Eq. 13)."""
    return cantilever.simulate_measurements(X, cantilever.K_SEMI_RIGID, rng=seed)


def write_csv(path: str | Path = Path(__file__).with_name("cantilever.csv"), seed: int = SEED) -> Path:
    y = simulate_measurements(seed)
    rows = [f"D{i + 1},deflection,{x:g},mm,{v:.6f}" for i, (x, v) in enumerate(zip(X, y))]
    write_text(path, "sensor,type,location,unit,value\n" + "\n".join(rows) + "\n")
    return Path(path)


if __name__ == "__main__":
    print(write_csv())
