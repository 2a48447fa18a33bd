"""A simply supported prestressed-concrete girder under a load test: a small
finite-element model (Euler-Bernoulli frame elements, NumPy) for the
``girder.toml`` example project.

Model class (three parameters, vectorised over parameter sets):

- ``E``      Young's modulus of the concrete, MPa;
- ``K_rot``  rotational stiffness of the left support (an abutment diaphragm
  partially fixes it), N mm/rad;
- ``k_h``    horizontal stiffness of each elastomeric bearing, N/mm. The
  bearings sit under the bottom flange, ``E_BEARING`` below the centroid, so
  restraining their sliding puts the girder in compression with a hogging
  moment (arch action) that stiffens it.

The "true" girder behind the simulated measurements also has a partially fixed
right support (``K_RIGHT_TRUE``), which the model class leaves out: a
systematic model error. Strain gauge SG5 is faulty (a zero offset after a
repair of its cable), so with it the model class is falsified, and the
leave-one-sensor-out diagnostic points at it.

Units: N, mm, MPa. Deflections are positive downwards, strains are at the
bottom fibre in microstrain (tension positive).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..stream.atomic import write_text

SPAN = 20_000.0            # mm
N_ELEMENTS = 20            # 1 m elements: every sensor and axle sits on a node
AREA = 4.5e5               # mm^2
INERTIA = 8.0e10           # mm^4
E_BEARING = 500.0          # mm, centroid above the bearings (bottom fibre)
Y_BOTTOM = 500.0           # mm, centroid to bottom fibre
#: Test truck: axle loads (N) at node positions (mm).
AXLES = {6_000.0: 100e3, 7_000.0: 150e3, 8_000.0: 150e3}
#: Sensors: (name, type, x in mm, unit), in the order of the model's columns.
SENSORS = (
    ("D1", "deflection", 5_000.0, "mm"), ("D2", "deflection", 10_000.0, "mm"),
    ("D3", "deflection", 15_000.0, "mm"),
    ("SG1", "strain", 1_000.0, "microstrain"), ("SG2", "strain", 4_000.0, "microstrain"),
    ("SG3", "strain", 7_000.0, "microstrain"), ("SG4", "strain", 10_000.0, "microstrain"),
    ("SG5", "strain", 13_000.0, "microstrain"), ("SG6", "strain", 16_000.0, "microstrain"),
    ("SG7", "strain", 19_000.0, "microstrain"),
)
#: The girder behind the measurements.
E_TRUE, K_ROT_TRUE, K_H_TRUE = 36e3, 3e11, 2e5
K_RIGHT_TRUE = 5e10        # unmodelled partial fixity of the right support, N mm/rad
NOISE_SD = {"deflection": 0.05, "strain": 2.0}   # mm, microstrain
FAULTY = ("SG5", -80.0)    # faulty gauge and its offset, microstrain
SEED = 7
CHUNK = 2048               # parameter sets per batched solve (bounds memory)

_NODES = N_ELEMENTS + 1
_LE = SPAN / N_ELEMENTS


def _node(x: float) -> int:
    k = x / _LE
    if abs(k - round(k)) > 1e-9:
        raise ValueError(f"x = {x} mm is not on a node (every {_LE:g} mm)")
    return int(round(k))


def _unit_stiffness() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """K = E K_E + K_rot K_R + k_h K_H + K_right K_RR, each part for a unit parameter (all dofs)."""
    n = 3 * _NODES  # (u, v, theta) per node
    L = _LE
    a, b = AREA / L, INERTIA / L**3
    ke = np.array([  # 2-D Euler-Bernoulli frame element, per unit E
        [a, 0, 0, -a, 0, 0],
        [0, 12 * b, 6 * b * L, 0, -12 * b, 6 * b * L],
        [0, 6 * b * L, 4 * b * L**2, 0, -6 * b * L, 2 * b * L**2],
        [-a, 0, 0, a, 0, 0],
        [0, -12 * b, -6 * b * L, 0, 12 * b, -6 * b * L],
        [0, 6 * b * L, 2 * b * L**2, 0, -6 * b * L, 4 * b * L**2],
    ])
    k_e = np.zeros((n, n))
    for e in range(N_ELEMENTS):
        dofs = slice(3 * e, 3 * e + 6)
        k_e[dofs, dofs] += ke
    k_rot = np.zeros((n, n))
    k_rot[2, 2] = 1.0
    k_right = np.zeros((n, n))
    k_right[3 * N_ELEMENTS + 2, 3 * N_ELEMENTS + 2] = 1.0
    # Bearing sliding u_b = u + e * theta (the bottom fibre lies e below the centroid).
    k_h = np.zeros((n, n))
    for node in (0, N_ELEMENTS):
        idx = [3 * node, 3 * node + 2]
        vec = np.array([1.0, E_BEARING])
        k_h[np.ix_(idx, idx)] += np.outer(vec, vec)
    return k_e, k_rot, k_h, k_right


def _observation() -> np.ndarray:
    """H: sensor readings = H @ d (all dofs). Strains use the element left of the gauge (right of node 0)."""
    h = np.zeros((len(SENSORS), 3 * _NODES))
    L = _LE
    for row, (_, kind, x, _) in enumerate(SENSORS):
        node = _node(x)
        if kind == "deflection":
            h[row, 3 * node + 1] = -1.0  # downwards positive
            continue
        e, xi = (node - 1, 1.0) if node > 0 else (0, 0.0)
        first = 3 * e
        # bottom-fibre strain du/dx + y_b v'' with Hermite curvatures at xi
        h[row, [first, first + 3]] = [-1.0 / L, 1.0 / L]
        h[row, [first + 1, first + 2, first + 4, first + 5]] = Y_BOTTOM * np.array([
            (-6 + 12 * xi) / L**2, (-4 + 6 * xi) / L, (6 - 12 * xi) / L**2, (-2 + 6 * xi) / L])
        h[row] *= 1e6  # microstrain
    return h


def _axle_loads() -> np.ndarray:
    f = np.zeros(3 * _NODES)
    for x, force in AXLES.items():
        f[3 * _node(x) + 1] -= force  # downwards
    return f


def _lane_load(w: float) -> np.ndarray:
    """Consistent nodal loads of a uniform downward load w (N/mm) over the span."""
    f = np.zeros(3 * _NODES)
    L = _LE
    for e in range(N_ELEMENTS):
        f[3 * e + 1] -= w * L / 2
        f[3 * e + 2] -= w * L**2 / 12
        f[3 * e + 4] -= w * L / 2
        f[3 * e + 5] += w * L**2 / 12
    return f


_H = _observation()
_FREE = np.array([d for d in range(3 * _NODES) if d not in (1, 3 * N_ELEMENTS + 1)])  # v = 0 at both bearings
#: The four unit stiffness matrices on the free dofs, flattened: K(theta) = coeff @ _PARTS.
_PARTS = np.stack([m[np.ix_(_FREE, _FREE)] for m in _unit_stiffness()]).reshape(4, -1)
_TRUCK = _axle_loads()


def displacements(theta, load: np.ndarray, k_right=0.0) -> np.ndarray:
    """Nodal displacements (n, 3 * nodes) for parameter sets theta = [E, K_rot, k_h] (n, 3).

    ``k_right`` is the rotational stiffness of the right support (0 in the model class).
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=np.float64))
    if theta.ndim != 2 or theta.shape[1] != 3:
        raise ValueError(f"theta: expected shape (n, 3) for [E, K_rot, k_h], got {theta.shape}")
    n_free = _FREE.size
    coeff = np.column_stack([theta, np.broadcast_to(np.asarray(k_right, dtype=np.float64), (theta.shape[0],))])
    f = load[_FREE]
    out = np.zeros((theta.shape[0], 3 * _NODES))
    for first in range(0, theta.shape[0], CHUNK):
        c = coeff[first:first + CHUNK]
        stiffness = (c @ _PARTS).reshape(c.shape[0], n_free, n_free)
        out[first:first + CHUNK, _FREE] = np.linalg.solve(stiffness, np.broadcast_to(f, (c.shape[0], n_free))[..., None])[..., 0]
    return out


def predict(theta) -> np.ndarray:
    """g(theta): the 10 sensor readings under the test truck, shape (n, 10)."""
    return displacements(theta, _TRUCK) @ _H.T


def midspan_deflection(theta, w: float = 40.0) -> np.ndarray:
    """Prognosis: midspan deflection (mm, downwards) under a uniform lane load w (N/mm)."""
    d = displacements(theta, _lane_load(w))
    return -d[:, 3 * _node(SPAN / 2) + 1]


def true_readings() -> np.ndarray:
    """Readings of the true girder (partially fixed right support), without noise or fault."""
    theta = np.array([[E_TRUE, K_ROT_TRUE, K_H_TRUE]])
    return (displacements(theta, _TRUCK, k_right=K_RIGHT_TRUE) @ _H.T)[0]


def simulate_measurements(seed: int = SEED) -> np.ndarray:
    """Measured values: true readings + sensor noise + the faulty gauge's offset (deterministic)."""
    rng = np.random.default_rng(seed)
    sd = np.array([NOISE_SD[kind] for _, kind, _, _ in SENSORS])
    y = true_readings() + rng.normal(0.0, sd)
    y[[s[0] for s in SENSORS].index(FAULTY[0])] += FAULTY[1]
    return y


def write_csv(path: str | Path | None = None, seed: int = SEED) -> Path:
    """Writes the measurements CSV shipped with ``girder.toml``."""
    path = Path(path) if path is not None else Path(__file__).parent / "projects" / "girder.csv"
    rows = [f"{name},{kind},{x:g},{unit},{v:.4f}" for (name, kind, x, unit), v in zip(SENSORS, simulate_measurements(seed))]
    write_text(path, "sensor,type,location,unit,value\n" + "\n".join(rows) + "\n")
    return path


if __name__ == "__main__":
    print(write_csv())
