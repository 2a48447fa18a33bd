"""The girder of :mod:`edmf_rs.examples.girder` as an OpenSeesPy model (optional:
``pip install openseespy``): the ``girder-opensees.toml`` example of a Python
model that wraps a finite-element program, evaluated by a pool of processes
(``workers = 2``; OpenSees keeps one global model per process).

The same girder, built from OpenSees elements: 20 ``elasticBeamColumn``
elements, the left support's rotational spring and the bearings' horizontal
springs as ``zeroLength`` elements, each bearing tied to the girder's axis by
a ``rigidLink`` 500 mm below it. Readings: deflections from the nodal
displacements, bottom-fibre strains N/(EA) + y_b M/(EI) from the element end
forces. Since both are exact Euler-Bernoulli frames under nodal loads, the
predictions equal :func:`edmf_rs.examples.girder.predict` to rounding.
"""

from __future__ import annotations

import numpy as np

from . import girder as g


def _one(e: float, k_rot: float, k_h: float, ops) -> list[float]:
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    n = g.N_ELEMENTS
    for i in range(n + 1):
        ops.node(i, i * g._LE, 0.0)
    ops.geomTransf("Linear", 1)
    for i in range(n):
        ops.element("elasticBeamColumn", i + 1, i, i + 1, g.AREA, e, g.INERTIA, 1)
    ops.uniaxialMaterial("Elastic", 1, k_rot)
    ops.uniaxialMaterial("Elastic", 2, k_h)
    ops.fix(0, 0, 1, 0)
    ops.fix(n, 0, 1, 0)
    # Left support: a rotational spring to ground.
    ops.node(1000, 0.0, 0.0)
    ops.fix(1000, 1, 1, 1)
    ops.element("zeroLength", 1000, 1000, 0, "-mat", 1, "-dir", 3)
    # Bearings: horizontal springs E_BEARING below the axis, tied to it rigidly.
    for k, node in enumerate((0, n)):
        x = node * g._LE
        bearing, ground = 2000 + k, 3000 + k
        ops.node(bearing, x, -g.E_BEARING)
        ops.node(ground, x, -g.E_BEARING)
        ops.fix(ground, 1, 1, 1)
        ops.rigidLink("beam", node, bearing)
        ops.element("zeroLength", 2000 + k, ground, bearing, "-mat", 2, "-dir", 1)
    ops.timeSeries("Linear", 1)
    ops.pattern("Plain", 1, 1)
    for x, force in g.AXLES.items():
        ops.load(g._node(x), 0.0, -force, 0.0)
    ops.constraints("Transformation")
    ops.numberer("RCM")
    ops.system("BandGeneral")
    ops.algorithm("Linear")
    ops.integrator("LoadControl", 1.0)
    ops.analysis("Static")
    if ops.analyze(1) != 0:
        raise RuntimeError(f"OpenSees analysis failed for E={e!r}, K_rot={k_rot!r}, k_h={k_h!r}")
    out = []
    for _, kind, x, _ in g.SENSORS:
        node = g._node(x)
        if kind == "deflection":
            out.append(-ops.nodeDisp(node, 2))
            continue
        # Gauge at the right end of the element left of its node (as in girder.py).
        forces = ops.eleResponse(node, "localForce")  # [N_i, V_i, M_i, N_j, V_j, M_j]
        axial, moment = forces[3], forces[5]
        out.append(1e6 * (axial / (e * g.AREA) + g.Y_BOTTOM * moment / (e * g.INERTIA)))
    return out


def predict(theta) -> np.ndarray:
    """g(theta) for rows [E, K_rot, k_h]: the 10 readings of girder.SENSORS, shape (n, 10).

    Examples
    --------
    >>> from edmf_rs.examples import girder
    >>> theta = [[36e3, 3e11, 2e5]]
    >>> bool(np.allclose(predict(theta), girder.predict(theta), rtol=1e-9, atol=1e-9))
    True
    """
    import openseespy.opensees as ops

    theta = np.atleast_2d(np.asarray(theta, dtype=np.float64))
    return np.array([_one(*row, ops) for row in theta]).reshape(theta.shape[0], len(g.SENSORS))
