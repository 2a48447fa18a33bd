"""Where to measure the girder of ``girder.toml``: candidate sensor locations
every 0.5 m along the span, deflections and bottom-fibre strains, under two
load cases (the test truck and the same truck driven the other way), for the
design project ``design_projects/girder-design.toml`` (``edmf-rs design``).

Predictions between the finite-element nodes use the element's Hermite shape
functions (deflection) and their second derivatives (curvature, hence strain).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..stream.atomic import write_text
from . import girder as gd

#: Candidate positions (mm): every 0.5 m, supports excluded (deflection 0 there).
POSITIONS = np.arange(500.0, gd.SPAN, 500.0)
#: Sensor costs (say, in hundreds of francs installed): an LVDT needs a frame.
COSTS = {"deflection": 3.0, "strain": 1.0}
UNITS = {"deflection": "mm", "strain": "microstrain"}
#: Load cases: axle positions (mm) -> loads (N).
LOAD_CASES = {
    "LC1": gd.AXLES,
    "LC2": {gd.SPAN - x: f for x, f in gd.AXLES.items()},  # the truck driven the other way
}


def _loads(axles: dict) -> np.ndarray:
    f = np.zeros(3 * gd._NODES)
    for x, force in axles.items():
        f[3 * gd._node(x) + 1] -= force
    return f


def observation_row(kind: str, x: float) -> np.ndarray:
    """Reading = row @ d (all dofs) for a deflection (mm, down) or bottom-fibre strain (microstrain) at x."""
    L = gd._LE
    k = x / L
    e = int(np.clip(np.ceil(k) - 1 if k > 0 else 0, 0, gd.N_ELEMENTS - 1))
    xi = k - e
    row = np.zeros(3 * gd._NODES)
    first = 3 * e
    if kind == "deflection":
        n = [1 - 3 * xi**2 + 2 * xi**3, L * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, L * (xi**3 - xi**2)]
        row[[first + 1, first + 2, first + 4, first + 5]] = -np.array(n)
        return row
    row[[first, first + 3]] = [-1.0 / L, 1.0 / L]
    row[[first + 1, first + 2, first + 4, first + 5]] = gd.Y_BOTTOM * np.array([
        (-6 + 12 * xi) / L**2, (-4 + 6 * xi) / L, (6 - 12 * xi) / L**2, (-2 + 6 * xi) / L])
    return row * 1e6


def candidates() -> list[tuple[str, str, float, float, str]]:
    """(name, type, location mm, cost, load case) of every candidate, in column order."""
    rows = []
    for case in LOAD_CASES:
        for kind, prefix in (("deflection", "D"), ("strain", "SG")):
            rows += [(f"{prefix}{x / 1000:g}-{case}", kind, float(x), COSTS[kind], case) for x in POSITIONS]
    return rows


def predict(theta):
    """Predictions at every candidate (n, 156), as a DataFrame named by candidate."""
    import pandas as pd

    rows = candidates()
    out = np.empty((np.atleast_2d(theta).shape[0], len(rows)))
    for case, axles in LOAD_CASES.items():
        cols = [j for j, r in enumerate(rows) if r[4] == case]
        h = np.array([observation_row(rows[j][1], rows[j][2]) for j in cols])
        out[:, cols] = gd.displacements(theta, _loads(axles)) @ h.T
    return pd.DataFrame(out, columns=[r[0] for r in rows])


def write_candidates(path: str | Path | None = None) -> Path:
    """Writes the candidate-locations CSV shipped with the design project."""
    path = Path(path) if path is not None else Path(__file__).parent / "design_projects" / "girder-candidates.csv"
    lines = [f"{n},{k},{x:g},{c:g},{case},{UNITS[k]}" for n, k, x, c, case in candidates()]
    write_text(path, "name,type,location,cost,load_case,unit\n" + "\n".join(lines) + "\n")
    return path


if __name__ == "__main__":
    print(write_candidates())
