"""Time per call of ``edmf_rs.falsify`` on small arrays (rows x 10 float64,
diagnostics on, default threads): what a loop of many small calls (adaptive
sampling, sensor-placement sweeps) pays per call. Median and 10th percentile
of ``--calls`` calls per size, after 100 warm-up calls.

    python benches/small_calls.py
"""

from __future__ import annotations

import argparse
import time

import edmf_rs
import numpy as np

from throughput_methods import machine


def per_call(rows: int, calls: int) -> tuple[float, float]:
    y = np.zeros(10)
    t = edmf_rs.Thresholds(low=[-2.0] * 10, high=[2.0] * 10)
    p = np.random.default_rng(0).normal(size=(rows, 10))
    for _ in range(100):
        edmf_rs.falsify(p, y, t, progress=False)
    times = []
    for _ in range(calls):
        start = time.perf_counter()
        edmf_rs.falsify(p, y, t, progress=False)
        times.append(time.perf_counter() - start)
    times.sort()
    return times[len(times) // 2], times[len(times) // 10]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", type=int, nargs="+", default=[100, 1000, 6000, 7000, 20000])
    ap.add_argument("--calls", type=int, default=2000)
    args = ap.parse_args(argv)
    print(machine())
    print(f"edmf_rs threads: {edmf_rs.get_num_threads()}")
    print(f"{'rows':>7} {'median us':>10} {'p10 us':>8}")
    for rows in args.rows:
        median, p10 = per_call(rows, args.calls)
        print(f"{rows:>7} {median * 1e6:>10.0f} {p10 * 1e6:>8.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
