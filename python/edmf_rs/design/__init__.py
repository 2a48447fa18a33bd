"""Measurement-system design: where to place sensors for EDMF.

- :func:`joint_entropy` and :func:`place_sensors`: hierarchical sensor
  placement by joint entropy of the binned predictions (Papadopoulou, Raphael,
  Smith & Sekhar 2014, Entropy 16(9):5078), per unit cost and within a budget
  (Bertola, Papadopoulou, Vernay & Smith 2017, Sensors 17(12):2904).
- :func:`expected_identifiability` and :func:`identifiability_curve`: expected
  candidate-set sizes from simulated measurements (Goulet & Smith 2013, Eqs. 4-8).
- :mod:`edmf_rs.design.reference`: the NumPy reference of these definitions.
"""

from . import reference
from .entropy import interval_widths, joint_entropy
from .identifiability import (
    Identifiability,
    IdentifiabilityCurve,
    expected_identifiability,
    identifiability_curve,
)
from .placement import TIE, SensorDesign, place_sensors

__all__ = [
    "TIE",
    "Identifiability",
    "IdentifiabilityCurve",
    "SensorDesign",
    "expected_identifiability",
    "identifiability_curve",
    "interval_widths",
    "joint_entropy",
    "place_sensors",
    "reference",
]
