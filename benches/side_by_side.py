"""Speed / read floor of a few cases in one line, to compare two builds side
by side: run it with each build's Python in turn (processes alternating, so a
slow spell of the host falls on both alike) and compare the lines.

    /path/to/old-venv/bin/python benches/side_by_side.py old
    /path/to/new-venv/bin/python benches/side_by_side.py main

Each case: 400 MB of predictions in memory, the read floor (``np.max`` over
the two halves on two threads at once) and ``edmf_rs.falsify`` (default
threads, ``keep_violations=False``) in turn, best of 7 each; the cell is
floor time / falsify time. "diag" is ``diagnostics=True``, "scr" False.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ThreadPoolExecutor

import edmf_rs
import numpy as np

from throughput_methods import in_memory

CASES = [(5, "float32", "typical", "scr"), (5, "float32", "typical", "diag"), (5, "float32", "worst", "diag"),
         (5, "float64", "worst", "diag"), (10, "float32", "typical", "diag"), (10, "float32", "worst", "diag"),
         (10, "float64", "typical", "diag"), (10, "float64", "worst", "diag"), (16, "float32", "typical", "diag"),
         (16, "float32", "worst", "diag"), (16, "float32", "typical", "scr"), (16, "float64", "worst", "diag"),
         (16, "float64", "typical", "diag"), (16, "float64", "worst", "scr"), (50, "float32", "worst", "diag"), (50, "float64", "typical", "diag"),
         (200, "float32", "worst", "diag"), (200, "float64", "worst", "diag"), (200, "float32", "typical", "diag"),
         (200, "float64", "typical", "diag")]


def ratio(pool, n_m: int, dtype: str, case: str, mode: str, mb: float, repeat: int) -> float:
    n = int(mb * 1e6) // (n_m * np.dtype(dtype).itemsize)
    p, y, t = in_memory(n, n_m, case, np.dtype(dtype).type)
    halves = (p[: n // 2], p[n // 2:])
    methods = {
        "floor": lambda: list(pool.map(np.max, halves)),
        "falsify": lambda: edmf_rs.falsify(p, y, t, diagnostics=mode == "diag", keep_violations=False,
                                           progress=False),
    }
    best = {name: float("inf") for name in methods}
    for k in range(repeat):
        for name in sorted(methods, reverse=k % 2 == 1):  # alternate which runs first
            start = time.perf_counter()
            methods[name]()
            best[name] = min(best[name], time.perf_counter() - start)
    return best["floor"] / best["falsify"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("label", help="name printed before the line (e.g. old, main)")
    ap.add_argument("--mb", type=float, default=400.0, help="array size in MB (default 400)")
    ap.add_argument("--repeat", type=int, default=7, help="best of k (default 7)")
    ap.add_argument("--case", nargs=4, action="append", metavar=("N_M", "DTYPE", "CASE", "MODE"),
                    help="a case instead of the default list, e.g. --case 16 float64 worst scr (repeatable)")
    args = ap.parse_args(argv)
    cases = [(int(n_m), dtype, case, mode) for n_m, dtype, case, mode in args.case] if args.case else CASES
    with ThreadPoolExecutor(2) as pool:
        cells = [f"{n_m} {dtype} {case} {mode} {ratio(pool, n_m, dtype, case, mode, args.mb, args.repeat):.2f}"
                 for n_m, dtype, case, mode in cases]
    print(f"{args.label}: " + " | ".join(cells), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
