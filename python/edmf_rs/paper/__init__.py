"""Goulet & Smith (2013), reproduced: the cantilever of Sec. 4, the
least-squares (Eq. 15) and Bayesian (Eq. 17) baselines, the coverage study of
Sec. 3.2 (Fig. 3), the reproduction behind ``edmf-rs reproduce`` and its figures.

Depends on the engine only; nothing in the engine depends on it.
"""
