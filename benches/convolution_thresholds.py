"""Threshold bounds by numerical convolution vs the Monte Carlo estimator, side by side.

For normal + uniform and lognormal + normal sources (phi = 0.95, Sidak, default
200,000 samples for Monte Carlo), prints each method's bias of the low/high
bound and excess width as % of the exact shortest interval's width (the
reference: a 2^18-cell convolution minimised by brentq-free bounded search,
as in mc_threshold_accuracy.py), and the time of threshold_bounds for 10 and
2,000 sensors (sources vectorised over the sensors by relative_to_measured;
20,000 Monte Carlo samples at 2,000 sensors).

    python benches/convolution_thresholds.py --seeds 8
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy import stats

import edmf_rs
from mc_threshold_accuracy import CASES, exact_cdf, exact_shortest


def accuracy(seeds: int, n_m: int) -> None:
    p = edmf_rs.sensor_probability(0.95, n_m)
    for name, (model, measurement) in CASES.items():
        grid, cdf = exact_cdf(model, measurement)
        lo, hi = exact_shortest(grid, cdf, p)
        w = hi - lo
        for method in ("monte-carlo", "convolution"):
            low, high = [], []
            for seed in range(seeds if method == "monte-carlo" else 1):
                c = edmf_rs.combine(model=model, measurement=measurement, n_sensors=n_m, seed=seed)
                t = edmf_rs.threshold_bounds(c, method=method)
                low.append(t.low)
                high.append(t.high)
            low, high = np.concatenate(low), np.concatenate(high)
            cov = np.interp(high, grid, cdf) - np.interp(low, grid, cdf)
            print(f"{name:20s} n_m={n_m:3d} {method:12s} low {100 * (low.mean() - lo) / w:+.4f} %  "
                  f"high {100 * (high.mean() - hi) / w:+.4f} %  width {100 * ((high - low).mean() / w - 1):+.4f} %  "
                  f"share coverage >= p {np.mean(cov >= p):.3f}")


def timing(n_m: int, n_samples: int) -> None:
    y = np.random.default_rng(0).uniform(0.5, 5.0, n_m)
    for name, fraction, noise in (("uniform + normal", stats.uniform(-0.2, 0.3), stats.norm(0, 0.05)),
                                  ("lognormal + normal", stats.lognorm(0.5, scale=0.1), stats.norm(0, 0.05))):
        t0 = time.perf_counter()
        c = edmf_rs.combine(model=edmf_rs.relative_to_measured(fraction, y), measurement=noise, n_samples=n_samples)
        t1 = time.perf_counter()
        if n_samples >= 200_000:
            edmf_rs.threshold_bounds(c, method="monte-carlo")
        t2 = time.perf_counter()
        conv = edmf_rs.threshold_bounds(c)
        t3 = time.perf_counter()
        assert set(conv.method) == {"convolution"}
        mc = f"{t2 - t1:.2f} s" if n_samples >= 200_000 else "(too few samples for p)"
        print(f"{name:20s} n_m={n_m:5d}, N={n_samples:,}: combine {t1 - t0:.2f} s, monte-carlo bounds {mc}, "
              f"convolution bounds {t3 - t2:.2f} s; "
              f"max numerical error {np.max(conv.se_high / conv.width):.1e} of the width")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=8)
    a = ap.parse_args()
    if a.seeds:
        for n_m in (10, 50):
            accuracy(a.seeds, n_m)
    timing(10, 200_000)
    timing(2000, 20_000)  # 200,000 samples x 2,000 sensors would be 3.2 GB
