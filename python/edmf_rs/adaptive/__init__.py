"""Adaptive EDMF (issue 16): waves of real model runs steered by Gaussian-process
emulators (one per sensor, or on the outputs' principal components when
sensors are many); the emulator proposes, the model decides (Eq. 8).

:func:`adaptive_falsify` is the entry point (also ``edmf_rs.adaptive_falsify``).
"""

from .basis import PCAEmulators
from .emulator import EmulatorError, SensorEmulators, Validation
from .result import AdaptiveResult, WaveRecord
from .screen import screen, screen_reference
from .waves import adaptive_falsify

__all__ = ["AdaptiveResult", "EmulatorError", "PCAEmulators", "SensorEmulators", "Validation", "WaveRecord",
           "adaptive_falsify", "screen", "screen_reference"]
