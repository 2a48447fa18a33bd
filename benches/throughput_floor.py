"""edmf_rs.falsify against the read floor, side by side in one run.

The floor is ``np.max`` over the two halves of the same array on two threads
at once (vectorised, GIL released): no method that reads every prediction can
beat it. For each sensor count, dtype and case (worst: every instance a
candidate; typical: about 95 % falsified) the table gives the floor, then
``edmf_rs.falsify`` with and without diagnostics (``keep_violations=False``,
default thread count), each as milliseconds and as speed / floor (1.0 = at the
floor). Every array holds the same number of bytes (``--mb``), so rows of 5
sensors are many and rows of 200 few.

    python benches/throughput.py --floor                      # the whole table
    python benches/throughput.py --floor --nm 5 10 --dtype f64 --cases worst

With ``--prefetch NAME...`` (``t1:8192``, ``nta:4096``, ``off``: see
``edmf_rs._core.prefetch``) both methods also run with each named prefetch in
the same rounds, and a last line gives, per name, the median over the cases
of the paired ratio (time with this CPU's prefetch / time with NAME, the
median over rounds of the ratio within a round): above 1, this CPU's is
faster.

Timings are best-of-k (``--repeat`` rounds, each running the floor and every
method once in a rotating order) with time.perf_counter (wall) and
time.process_time (CPU seconds of all threads of this process). On a shared
machine a thread waiting for a core inflates wall time but not CPU time, so
the CPU ratio is the steadier one there; ``os.getloadavg()`` is printed with
the table.
"""

from __future__ import annotations

import argparse
import os
from concurrent.futures import ThreadPoolExecutor

import edmf_rs
import numpy as np
import time
from edmf_rs import _core

from throughput_methods import in_memory, machine, read_floor

DTYPES = {"f64": np.float64, "f32": np.float32}


def falsify(p, y, t, diagnostics: bool):
    return edmf_rs.falsify(p, y, t, diagnostics=diagnostics, keep_violations=False, progress=False)


def with_prefetch(name: str, fn):
    """`fn` run with the kernels' prefetch `name`, this CPU's restored after."""
    def run():
        own = _core.prefetch()
        _core.set_prefetch(name)
        try:
            return fn()
        finally:
            _core.set_prefetch(own)
    return run


def interleaved(fns: dict, repeat: int) -> dict[str, tuple[list, list]]:
    """Wall and CPU seconds (all threads) of each of `fns` in each of
    `repeat` rounds, every round running each once in a rotating order, so a
    slow spell of a shared machine falls on all of them alike."""
    times = {name: ([], []) for name in fns}
    names = list(fns)
    for k in range(repeat):
        for name in names[k % len(names):] + names[:k % len(names)]:
            w, c = time.perf_counter(), time.process_time()
            fns[name]()
            times[name][1].append(time.process_time() - c)
            times[name][0].append(time.perf_counter() - w)
    return times


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nm", type=int, nargs="+", default=[5, 10, 16, 50, 200], help="sensor counts")
    ap.add_argument("--dtype", nargs="+", default=["f64", "f32"], choices=sorted(DTYPES))
    ap.add_argument("--cases", nargs="+", default=["worst", "typical"], choices=["worst", "typical"])
    ap.add_argument("--mb", type=float, default=800.0, help="array size in MB (default 800: 1e7 x 10 f64)")
    ap.add_argument("--repeat", type=int, default=7, help="best of k rounds (default 7)")
    ap.add_argument("--prefetch", nargs="+", default=[], metavar="NAME",
                    help="also run with these prefetches (t1:8192, nta:4096, off, ...), side by side")
    args = ap.parse_args(argv)
    for name in args.prefetch:
        with_prefetch(name, lambda: None)()  # a bad name fails here, before any work
    print(machine())
    print(f"prefetch for this CPU: {_core.prefetch()}")
    print(f"edmf_rs threads: {edmf_rs.get_num_threads()}; load average at start: "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    paired = {name: [] for name in args.prefetch}
    print(f"{'n_m':>4} {'dtype':>5} {'case':>7} {'rows':>11}  {'method':<26} {'ms':>8} {'floor ms':>9} "
          f"{'speed/floor':>11} {'cpu ms':>8} {'floor cpu':>9} {'cpu ratio':>9}")
    with ThreadPoolExecutor(2) as pool:
        for n_m in args.nm:
            for name in args.dtype:
                dtype = DTYPES[name]
                n = max(1, int(args.mb * 1e6) // (n_m * np.dtype(dtype).itemsize))
                for case in args.cases:
                    p, y, t = in_memory(n, n_m, case, dtype)
                    results = [falsify(p, y, t, d) for d in (True, False)]
                    share = results[1].n_candidates / n
                    assert results[0].n_candidates == results[1].n_candidates
                    assert (case == "worst") == (share == 1.0), (case, share)
                    fns = {"floor": lambda: read_floor(p, pool, 2),
                           "diagnostics": lambda: falsify(p, y, t, True),
                           "no diagnostics": lambda: falsify(p, y, t, False)}
                    for pf in args.prefetch:
                        for d, label in ((True, "diagnostics"), (False, "no diagnostics")):
                            fns[f"{label}, {pf}"] = with_prefetch(pf, lambda d=d: falsify(p, y, t, d))
                    runs = interleaved(fns, args.repeat)
                    floor = [min(x) for x in runs["floor"]]
                    for method, (walls, cpus) in runs.items():
                        s, c = min(walls), min(cpus)
                        print(f"{n_m:>4} {name:>5} {case:>7} {n:>11,}  {method:<26} {s * 1e3:>8.1f} "
                              f"{floor[0] * 1e3:>9.1f} {floor[0] / s:>11.2f} {c * 1e3:>8.1f} "
                              f"{floor[1] * 1e3:>9.1f} {floor[1] / c:>9.2f}", flush=True)
                    for pf in args.prefetch:
                        for label in ("diagnostics", "no diagnostics"):
                            own, other = np.array(runs[label][0]), np.array(runs[f"{label}, {pf}"][0])
                            paired[pf].append(float(np.median(other / own)))
                    del p, results
    for pf, ratios in paired.items():
        print(f"prefetch {_core.prefetch()} against {pf}: median over {len(ratios)} cases of the paired ratio "
              f"(time with {pf} / time with {_core.prefetch()}) {np.median(ratios):.3f} "
              f"(range {min(ratios):.3f}-{max(ratios):.3f})")
    print(f"load average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
