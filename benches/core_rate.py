"""What one core's kernel alone reads per second, from L2: the ceiling the
CPU puts on the floor ratio of ``benches/throughput.py --floor``. Each call
falsifies 240 KiB of rows (under the 65,536 predictions that run on the
calling thread, so no pool hand-over), 2,000 calls a round, best of 7 rounds,
one thread. Two cores reading at this rate from memory would read
``2 x GB/s``; where that is below 0.9 of the floor's rate, the kernel, not the
memory, sets the pace. Run it again with ``EDMF_RS_ISA=avx2`` for the AVX2
kernels.

    python benches/core_rate.py
"""

from __future__ import annotations

import argparse
import math
import time

import edmf_rs
import numpy as np
from edmf_rs import _core
from scipy.special import erfinv

from throughput_methods import machine

KIB = 240


def rows_of(n_m: int, dtype, case: str) -> tuple[np.ndarray, np.ndarray]:
    """Measurements and 240 KiB of predictions, the cases of ``hash_cost.py``."""
    rng = np.random.default_rng(0)
    n = KIB * 1024 // (n_m * np.dtype(dtype).itemsize)
    y = np.linspace(-1.0, 1.0, n_m)
    if case == "worst":  # every residual inside the bounds: all candidates
        r = rng.random((n, n_m)) * 1.98 - 0.99
    else:  # P(candidate) = 5 %, every row's sensors visited for the diagnostics
        r = rng.standard_normal((n, n_m)) / (math.sqrt(2.0) * erfinv(0.05 ** (1.0 / n_m)))
    return y, np.ascontiguousarray((r + y).astype(dtype))


def rate(y: np.ndarray, data: np.ndarray, diagnostics: bool, calls: int, rounds: int) -> float:
    """GB/s of the best round."""
    n_m, best = len(y), math.inf
    for _ in range(rounds):
        acc = _core.Falsifier(y, np.full(n_m, -1.0), np.full(n_m, 1.0), diagnostics=diagnostics,
                              keep_violations=False)
        start = time.perf_counter()
        for _ in range(calls):
            acc.update(data)
        best = min(best, (time.perf_counter() - start) / calls)
    return data.nbytes / best / 1e9


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nm", type=int, nargs="+", default=[5, 10, 16, 50, 200])
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args(argv)
    threads = edmf_rs.get_num_threads()
    edmf_rs.set_num_threads(1)
    try:
        print(machine())
        print(f"one thread; {KIB} KiB a call, {args.calls} calls a round, best of {args.rounds} rounds")
        head = f"{'dtype':7} {'n_m':>4} {'case':7} {'diagnostics':>12} {'screen':>8}   (GB/s per core)"
        print(head)
        print("-" * len(head))
        for dtype in (np.float64, np.float32):
            for n_m in args.nm:
                for case in ("worst", "typical"):
                    y, data = rows_of(n_m, dtype, case)
                    on, off = (rate(y, data, d, args.calls, args.rounds) for d in (True, False))
                    print(f"{np.dtype(dtype).name:7} {n_m:4d} {case:7} {on:12.1f} {off:8.1f}", flush=True)
    finally:
        edmf_rs.set_num_threads(threads)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
