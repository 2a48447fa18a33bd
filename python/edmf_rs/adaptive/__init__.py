"""Adaptive EDMF (issue 16): waves of real model runs steered by per-sensor
Gaussian-process emulators; the emulator proposes, the model decides (Eq. 8)."""
