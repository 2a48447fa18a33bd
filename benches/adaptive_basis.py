"""Emulator fit time: one GP per sensor against GPs on principal components (issue 16).

A model of 40 sensors that are linear combinations of 3 latent outputs (the
model of tests/adaptive/test_adaptive_basis.py). Both emulators are fitted on
the same runs, side by side in one process, and screen the same sample: the
fit time of each, their ratio, and how many points each keeps.

    python benches/adaptive_basis.py [--out benches/results-adaptive-basis.txt]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
from edmf_rs.adaptive.basis import PCAEmulators
from edmf_rs.adaptive.design import sobol_points
from edmf_rs.adaptive.emulator import SensorEmulators
from edmf_rs.adaptive.screen import screen

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "adaptive"))
from test_adaptive_basis import THRESHOLDS, Y, model  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from adaptive import cpu_model, finish  # noqa: E402


def timed(make):
    wall, cpu = time.perf_counter(), time.process_time()
    out = make()
    return out, time.perf_counter() - wall, time.process_time() - cpu


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, nargs="+", default=[24, 48, 96])
    ap.add_argument("--out", default="benches/results-adaptive-basis.txt")
    args = ap.parse_args()
    lines = [f"benches/adaptive_basis.py on {cpu_model()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
             f"load average at the start {os.getloadavg()[0]:.1f}",
             "40 sensors = linear combinations of 3 latent outputs of 2 parameters; fit = hyperparameter search "
             "and factorisation; screening sample 2^14, c = 3"]
    x = sobol_points(2**14, 2, 1)
    for n in args.runs:
        u = sobol_points(n, 2, 0)
        g = model(u)
        per_sensor, ws, cs = timed(lambda: SensorEmulators(u, g))
        pca, wp, cp = timed(lambda: PCAEmulators(u, g))
        kept_s = screen(*per_sensor.predict(x), Y, THRESHOLDS, 3.0)[0]
        kept_p = screen(*pca.predict(x), Y, THRESHOLDS, 3.0)[0]
        lines.append(f"  {n:>3} runs: per sensor (40 GPs) {ws:7.2f} s wall {cs:7.2f} s CPU; PCA "
                     f"({pca.n_components} GPs) {wp:6.2f} s wall {cp:6.2f} s CPU; {ws / wp:5.1f} x less wall time; "
                     f"kept {kept_s.size} (per sensor) and {kept_p.size} (PCA), "
                     f"{np.setdiff1d(kept_s, kept_p).size} kept by the per-sensor emulators only")
        print(lines[-1], flush=True)
    finish(lines, args.out)


if __name__ == "__main__":
    main()
