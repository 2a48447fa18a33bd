"""The girder as a CalculiX (``ccx``) model: the ``girder-ccx.toml`` example of
an external finite-element program driven through an input-deck template.

The 20 m girder of :mod:`edmf_rs.examples.girder` (same section and test
truck), pinned at the left support and resting on a vertical bearing of
stiffness ``k_v`` at the right one, modelled with 20 quadratic beam elements
(B32R, which CalculiX expands into 20-node bricks: shear deformation
included). Two parameters: ``E`` (MPa) and ``k_v`` (N/mm); three sensors:
deflections D1..D3 at 5, 10 and 15 m (mm, downwards).

:func:`deflections` is the analytic Euler-Bernoulli answer for the same
girder (Roark's simply supported beam under point loads, plus the rigid tilt
from the spring's compression); CalculiX deflects 0.5-1.5 % more (shear
deformation and discretisation), which the project's model uncertainty covers.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..stream.atomic import write_text

SPAN = 20_000.0                  # mm
AREA, INERTIA = 4.5e5, 8.0e10    # mm^2, mm^4 (as the girder example)
AXLES = {6_000.0: 100e3, 7_000.0: 150e3, 8_000.0: 150e3}   # x (mm): load (N)
SENSORS = (("D1", 5_000.0), ("D2", 10_000.0), ("D3", 15_000.0))
N_ELEMENTS = 20
E_TRUE, K_V_TRUE = 36e3, 2e5
NOISE_SD = 0.05                  # mm
SEED = 11
PROJECTS = Path(__file__).parent / "projects"


def _node(x: float) -> int:
    """CalculiX node number at x (three nodes per element, numbered from 1)."""
    return int(round(x / (SPAN / (2 * N_ELEMENTS)))) + 1


def deflections(theta) -> np.ndarray:
    """Analytic Euler-Bernoulli deflections (n, 3), mm downwards, for rows [E, k_v].

    Examples
    --------
    >>> deflections([[36e3, 1e12]]).round(2).tolist()
    [[15.45, 20.4, 13.29]]
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=np.float64))
    e, k_v = theta[:, 0:1], theta[:, 1:2]
    x = np.array([s[1] for s in SENSORS])
    bending = np.zeros(3)
    reaction = 0.0
    for a, p in AXLES.items():  # Roark, Table 8.1 case 1e: point load at a on a span L
        b = SPAN - a
        left = p * b * x * (SPAN**2 - b**2 - x**2) / (6 * SPAN)
        right = p * a * (SPAN - x) * (SPAN**2 - a**2 - (SPAN - x) ** 2) / (6 * SPAN)
        bending += np.where(x <= a, left, right)
        reaction += p * a / SPAN
    return bending / (e * INERTIA) + (reaction / k_v) * x / SPAN


def read_dat(path) -> dict[str, float]:
    """Parser for CalculiX's ``girder.dat``: the *NODE PRINT block of U, as
    ``{"D1": ..., "D2": ..., "D3": ...}`` (mm, downwards positive).

    Raises
    ------
    ValueError
        No displacement block, or a sensor's node missing from it.
    """
    values: dict[int, float] = {}
    block = False
    for line in Path(path).read_text().splitlines():
        if line.strip().startswith("displacements"):
            block = True
            continue
        parts = line.split()
        if block and len(parts) == 4:
            values[int(parts[0])] = -float(parts[2])
        elif block and parts:
            block = False
    if not values:
        raise ValueError(f"{Path(path).name}: no displacement block (*NODE PRINT ... U) found")
    try:
        return {name: values[_node(x)] for name, x in SENSORS}
    except KeyError as exc:
        raise ValueError(f"{Path(path).name}: node {exc.args[0]} missing from the displacement block") from None


def deck() -> str:
    """The input-deck template (``girder.inp``), with placeholders {E} and {k_v}."""
    h = math.sqrt(12 * INERTIA / AREA)  # a rectangle with the girder's A and I
    b = AREA / h
    n_nodes = 2 * N_ELEMENTS + 1
    lines = ["** Girder of edmf_rs.examples.girder_ccx: 20 m span, 20 quadratic beam elements (B32R),",
             "** pinned at x = 0, on a vertical spring (bearing) at x = 20 m. Units: N, mm, MPa.",
             "** {E} and {k_v} are replaced by each model instance's parameters.",
             "*NODE, NSET=NALL"]
    lines += [f"{i + 1}, {i * SPAN / (n_nodes - 1):.1f}, 0.0, 0.0" for i in range(n_nodes)]
    lines += [f"1001, {SPAN:.1f}, -1000.0, 0.0", "*ELEMENT, TYPE=B32R, ELSET=EBEAM"]
    lines += [f"{e + 1}, {2 * e + 1}, {2 * e + 2}, {2 * e + 3}" for e in range(N_ELEMENTS)]
    lines += ["*ELEMENT, TYPE=SPRINGA, ELSET=EBEARING", f"101, {n_nodes}, 1001",
              "*NSET, NSET=SENSORS", ", ".join(str(_node(x)) for _, x in SENSORS),
              "*MATERIAL, NAME=CONCRETE", "*ELASTIC", "{E}, 0.2",
              "*BEAM SECTION, ELSET=EBEAM, MATERIAL=CONCRETE, SECTION=RECT", f"{b:.6f}, {h:.6f}", "0.0, 0.0, 1.0",
              "*SPRING, ELSET=EBEARING", "{k_v}",
              "*BOUNDARY", "1, 1, 2", "NALL, 3, 3", "1, 4, 4", "1001, 1, 3",
              "*STEP", "*STATIC", "*CLOAD"]
    lines += [f"{_node(x)}, 2, {-p:.1f}" for x, p in AXLES.items()]
    lines += ["*NODE PRINT, NSET=SENSORS", "U", "*END STEP"]
    return "\n".join(lines) + "\n"


def simulate_measurements(seed: int = SEED) -> np.ndarray:
    """Readings of the true girder (analytic, E_TRUE and K_V_TRUE) plus LVDT noise (deterministic)."""
    rng = np.random.default_rng(seed)
    return deflections([[E_TRUE, K_V_TRUE]])[0] + rng.normal(0.0, NOISE_SD, len(SENSORS))


def write_files(folder: str | Path | None = None) -> Path:
    """Writes girder.inp and girder-ccx.csv shipped with ``girder-ccx.toml``."""
    folder = Path(folder) if folder is not None else PROJECTS
    write_text(folder / "girder.inp", deck())
    rows = [f"{name},deflection,{x:g},mm,{v:.4f}" for (name, x), v in zip(SENSORS, simulate_measurements())]
    write_text(folder / "girder-ccx.csv", "sensor,type,location,unit,value\n" + "\n".join(rows) + "\n")
    return folder


if __name__ == "__main__":
    print(write_files())
