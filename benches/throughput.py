"""Throughput of edmf_rs.falsify against NumPy, in instances per second.

One run prints the machine and one table: for each N, n_m and case (worst:
every instance is a candidate, so no early exit; typical: over 90 % of the
instances are falsified), the rate of

- the memory-read probe ``np.sum`` over the same array,
- the read floor on every core: ``np.max`` over one slice per thread, at once
  (no method that reads every value can beat it),
- the NumPy reference ``edmf_rs.reference.falsify`` (the plain NumPy oracle,
  the same outputs as ``diagnostics=True``), one-shot and in chunks,
- the leanest NumPy rule, candidates only:
  ``np.all((P - y >= lo) & (P - y <= hi), axis=1)``, one-shot and in chunks,
- a per-instance Python loop as EDMF scripts often do it (on a subset),
- ``edmf_rs.falsify`` with 1 and 2 threads, with and without diagnostics,

with ratios to the probe, to the NumPy reference and to the lean rule
(one-shot in memory, chunked for files). Arrays that do not fit the memory budget are
streamed from a .npy file in a temporary folder (written in chunks; the
probe then reads the file in chunks with ``readinto``); with --refeed-gb,
cases whose file would exceed --max-file-gb stream one in-memory block
again and again instead (src "iter"). A last table streams
an N x 16 float32 file (N = 10^8 by default) and measures the peak RSS of
the edmf_rs run in a subprocess.

    python benches/throughput.py --quick               # smoke run, a minute
    python benches/throughput.py --n 2000000 --nm 50   # one case
    python benches/throughput.py --floor               # speed / read floor per n_m (throughput_floor.py)
    python benches/throughput.py                       # everything (10^5..10^8: long, needs disk)

Timings are best-of-k with time.perf_counter; files are read warm (they
were just written, so they sit in the page cache when RAM allows); with
--cold the streaming case is also timed from disk (the file evicted from the
page cache with posix_fadvise before each run).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import edmf_rs
import numpy as np
from throughput_methods import (
    best,
    edmf,
    evict,
    file_numpy_reference,
    file_numpy_rule,
    file_read,
    in_memory,
    machine,
    numpy_chunked,
    numpy_reference,
    numpy_reference_chunked,
    numpy_rule,
    python_loop,
    ram_bytes,
    read_floor,
    to_file,
)

# -- table -----------------------------------------------------------------------

HEADER = (f"{'N':>11} {'n_m':>4} {'case':>7} {'src':>4}  {'method':<38} {'time s':>8} {'inst/s':>10} "
          f"{'x probe':>8} {'x numpy':>8} {'x rule':>7}")


def row(n, n_m, case, src, method, seconds, n_timed, probe_rate, numpy_rate=0.0, rule_rate=0.0):
    """One table line; ratios against the read probe, the NumPy reference and the
    lean NumPy rule (one-shot in memory, chunked for files), all measured in this run."""
    rate = n_timed / seconds if seconds else float("nan")

    def ratio(base):
        return rate / base if base else float("nan")

    line = (f"{n:>11,} {n_m:>4} {case:>7} {src:>4}  {method:<38} {seconds:>8.3f} {rate:>10.3g} "
            f"{ratio(probe_rate):>8.2f} {ratio(numpy_rate):>8.1f} {ratio(rule_rate):>7.1f}")
    print(line, flush=True)
    return rate


def one_shot(n, n_m, case, name, method, temporaries, probe, args, numpy=0.0) -> float:
    """Times a NumPy method on the whole array, if its temporaries (bytes) fit the budget."""
    if temporaries > args.mem_budget:
        skipped(n, n_m, case, "mem", f"{name}, one-shot", "temporaries exceed the memory budget")
        return 0.0
    return row(n, n_m, case, "mem", f"{name}, one-shot", best(method, args.repeat), n, probe, numpy)


def edmf_rows(n, n_m, case, src, source, y, t, args, rates, threads=None, setup=None, suffix=""):
    """Times ``edmf_rs.falsify`` with and without diagnostics on each thread count;
    ``source()`` gives the predictions afresh for every call (a generator is used up)."""
    for d in (True, False):
        for th in threads or args.threads:
            row(n, n_m, case, src, f"edmf_rs {th} thr, diagnostics={d}{suffix}",
                best(lambda th=th, d=d: edmf(source(), y, t, th, d), args.repeat, setup), n, *rates)


def skipped(n, n_m, case, src, method, why):
    print(f"{n:>11,} {n_m:>4} {case:>7} {src:>4}  {method:<38} {'-':>8} {'-':>10} {'-':>8}  ({why})", flush=True)


def bench_case(n, n_m, case, args, tmp: Path):
    dtype = np.float64
    nbytes = n * n_m * 8
    if nbytes <= args.mem_budget:
        p, y, t = in_memory(n, n_m, case, dtype)
        probe = row(n, n_m, case, "mem", "probe: np.sum", best(lambda: np.sum(p), args.repeat), n, 0)
        k = max(args.threads)
        with ThreadPoolExecutor(k) as pool:
            floor = row(n, n_m, case, "mem", f"read floor: np.max on {k} threads",
                        best(lambda: read_floor(p, pool, k), args.repeat), n, probe)
        # One-shot temporaries: about 4.5 arrays' worth for the reference, 3.2 for the rule.
        numpy = one_shot(n, n_m, case, "numpy reference", lambda: numpy_reference(p, y, t), 4.5 * nbytes,
                         probe, args)
        chunked = row(n, n_m, case, "mem", "numpy reference, chunked",
                      best(lambda: numpy_reference_chunked(p, y, t), args.repeat), n, probe, numpy)
        numpy = numpy or chunked
        rule = one_shot(n, n_m, case, "numpy rule (candidates only)", lambda: numpy_rule(p, y, t), 3.2 * nbytes,
                        probe, args, numpy)
        chunked = row(n, n_m, case, "mem", "numpy rule (candidates only), chunked",
                      best(lambda: numpy_chunked(p, y, t), args.repeat), n, probe, numpy, rule)
        rule = rule or chunked
        print(f"{'':>30}(the read floor is {floor / numpy:.1f}x the NumPy reference and {floor / rule:.1f}x the rule: "
              "the most any method that reads every value reaches here)", flush=True)
        sub = p[:min(n, args.loop_n)]
        row(n, n_m, case, "mem", f"python loop ({len(sub):,} inst.)", best(lambda: python_loop(sub, y, t), 1),
            len(sub), probe, numpy, rule)
        edmf_rows(n, n_m, case, "mem", lambda: p, y, t, args, (probe, numpy, rule))
        del p
        return
    if nbytes > args.max_file:
        if args.refeed_gb:
            bench_refed(n, n_m, case, args)
        else:
            skipped(n, n_m, case, "file", "all", f"{nbytes / 2**30:.0f} GiB file > --max-file-gb")
        return
    path = tmp / f"bench-{n}-{n_m}-{case}.npy"
    try:
        y, t = to_file(path, n, n_m, case, dtype)
        probe = row(n, n_m, case, "file", "probe: readinto chunks", best(lambda: file_read(path), args.repeat), n, 0)
        skipped(n, n_m, case, "file", "numpy one-shot", "does not fit the memory budget")
        numpy = row(n, n_m, case, "file", "numpy reference, chunked (readinto)",
                    best(lambda: file_numpy_reference(path, y, t), args.repeat), n, probe)
        rule = row(n, n_m, case, "file", "numpy rule, chunked (readinto)",
                   best(lambda: file_numpy_rule(path, y, t), args.repeat), n, probe, numpy)
        edmf_rows(n, n_m, case, "file", lambda: path, y, t, args, (probe, numpy, rule))
    finally:
        path.unlink(missing_ok=True)


def bench_refed(n, n_m, case, args):
    """N instances too many for the disk: one in-memory block (larger than the
    caches) fed again and again as a stream of chunks, so every method reads
    N x n_m values from memory; NumPy works through each block in chunks."""
    block_rows = max(1, int(args.refeed_gb * 2**30) // (n_m * 8))
    block, y, t = in_memory(min(n, block_rows), n_m, case, np.float64)

    def blocks():
        for first in range(0, n, len(block)):
            yield block[:min(len(block), n - first)]

    src = "iter"
    probe = row(n, n_m, case, src, "probe: np.sum", best(lambda: [np.sum(b) for b in blocks()], args.repeat), n, 0)
    k = max(args.threads)
    with ThreadPoolExecutor(k) as pool:
        row(n, n_m, case, src, f"read floor: np.max on {k} threads",
            best(lambda: [read_floor(b, pool, k) for b in blocks()], args.repeat), n, probe)
    numpy = row(n, n_m, case, src, "numpy reference, chunked",
                best(lambda: edmf_rs.concatenate([numpy_reference_chunked(b, y, t) for b in blocks()]),
                     args.repeat), n, probe)
    rule = row(n, n_m, case, src, "numpy rule (candidates only), chunked",
               best(lambda: [numpy_chunked(b, y, t) for b in blocks()], args.repeat), n, probe, numpy)
    sub = block[:min(n, args.loop_n)]
    row(n, n_m, case, src, f"python loop ({len(sub):,} inst.)", best(lambda: python_loop(sub, y, t), 1),
        len(sub), probe, numpy, rule)
    edmf_rows(n, n_m, case, src, blocks, y, t, args, (probe, numpy, rule))


RSS_CHILD = """
import sys, time, edmf_rs, numpy as np
from edmf_rs import Thresholds
n_m = 16
y = np.linspace(-1.0, 1.0, n_m)
t = Thresholds(np.full(n_m, -1.0), np.full(n_m, 1.0))
if sys.argv[1] != "import-only":
    edmf_rs.falsify(sys.argv[1], y, t, diagnostics=True, progress=False)
"""

RSS_PARENT = """
import resource, subprocess, sys
subprocess.run([sys.executable, "-c", sys.argv[1], sys.argv[2]], check=True)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)  # KiB on Linux
"""


def peak_rss_mib(path_or_flag: str) -> float:
    """Peak RSS of a fresh process running edmf_rs.falsify on the file, as
    seen by its parent (RUSAGE_CHILDREN of a helper that runs only it)."""
    out = subprocess.run([sys.executable, "-c", RSS_PARENT, RSS_CHILD, path_or_flag], check=True,
                         capture_output=True, text=True).stdout
    return int(out.split()[-1]) / 1024


def bench_streaming(args, tmp: Path):
    n, n_m = args.streaming_n, 16
    path = tmp / f"stream-{n}-{n_m}.npy"
    print(f"\nStreaming: {n:,} x {n_m} float32 from a .npy file ({n * n_m * 4 / 2**30:.1f} GiB), typical case")
    print(HEADER)
    try:
        start = time.perf_counter()
        y, t = to_file(path, n, n_m, "typical", np.float32)
        print(f"  (file written in {time.perf_counter() - start:.1f} s)", flush=True)
        probe = row(n, n_m, "typical", "file", "numpy readinto chunks", best(lambda: file_read(path), args.repeat), n, 0)
        numpy = row(n, n_m, "typical", "file", "numpy reference, chunked (readinto)",
                    best(lambda: file_numpy_reference(path, y, t), args.repeat), n, probe)
        rule = row(n, n_m, "typical", "file", "numpy rule, chunked (readinto)",
                   best(lambda: file_numpy_rule(path, y, t), args.repeat), n, probe, numpy)
        edmf_rows(n, n_m, "typical", "file", lambda: str(path), y, t, args, (probe, numpy, rule))
        # The kernel alone on the same data, in memory: the ceiling for streaming.
        m = min(n, 20_000_000)
        with open(path, "rb") as fh:
            np.lib.format.read_magic(fh)
            np.lib.format.read_array_header_2_0(fh)
            head = np.fromfile(fh, dtype=np.float32, count=m * n_m).reshape(m, n_m)
        edmf_rows(m, n_m, "typical", "mem", lambda: head, y, t, args, (probe,), threads=[max(args.threads)])
        head = None  # frees the 1.3 GB before the cold runs
        if args.cold:
            def cold():
                evict(path)

            probe = row(n, n_m, "typical", "disk", "numpy readinto chunks (cold)",
                        best(lambda: file_read(path), args.repeat, cold), n, 0)
            edmf_rows(n, n_m, "typical", "disk", lambda: str(path), y, t, args, (probe,),
                      threads=[max(args.threads)], setup=cold, suffix=" (cold)")
        base = peak_rss_mib("import-only")
        peak = peak_rss_mib(str(path))
        print(f"  peak RSS of a process running edmf_rs.falsify on the file: {peak:.0f} MiB "
              f"(of which {base:.0f} MiB just importing edmf_rs); the file is {path.stat().st_size / 2**20:,.0f} MiB")
    finally:
        path.unlink(missing_ok=True)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if "--floor" in argv:  # the speed / floor table has its own options (throughput_floor.py)
        import throughput_floor

        return throughput_floor.main([a for a in argv if a != "--floor"])
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: small N, few repeats")
    ap.add_argument("--n", type=int, nargs="+", help="N values (default 1e5 1e6 1e7 1e8)")
    ap.add_argument("--nm", type=int, nargs="+", help="sensor counts (default 10 50 200)")
    ap.add_argument("--cases", nargs="+", default=["worst", "typical"], choices=["worst", "typical"])
    ap.add_argument("--max-n", type=int, default=None, help="skip N above this")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeat", type=int, default=3, help="best of k (default 3)")
    ap.add_argument("--loop-n", type=int, default=20_000, help="instances timed in the Python loop")
    ap.add_argument("--mem-budget-gb", type=float, default=None,
                    help="largest in-memory array (default: min(RAM/4, 6) GiB); larger N use a file")
    ap.add_argument("--max-file-gb", type=float, default=16.0, help="no file larger than this")
    ap.add_argument("--refeed-gb", type=float, default=0.0,
                    help="cases beyond --max-file-gb: stream N rows by feeding one block of this size "
                         "again and again from memory (src 'iter'); 0 skips them")
    ap.add_argument("--streaming-n", type=int, default=10**8, help="rows of the N x 16 float32 streaming case")
    ap.add_argument("--no-streaming", action="store_true", help="skip the streaming case")
    ap.add_argument("--streaming-only", action="store_true", help="run only the streaming case")
    ap.add_argument("--cold", action="store_true",
                    help="also stream the file cold (evicted from the page cache before each run)")
    ap.add_argument("--tmp", default=None, help="folder for the temporary .npy files")
    args = ap.parse_args(argv)
    if args.quick:
        args.n = args.n or [10**5, 10**6]
        args.nm = args.nm or [10, 50]
        args.repeat = min(args.repeat, 2)
        args.loop_n = min(args.loop_n, 5_000)
        args.streaming_n = min(args.streaming_n, 2 * 10**6)
    args.n = args.n or [10**5, 10**6, 10**7, 10**8]
    args.nm = args.nm or [10, 50, 200]
    if args.max_n:
        args.n = [n for n in args.n if n <= args.max_n]
        args.streaming_n = min(args.streaming_n, args.max_n)
    args.mem_budget = (args.mem_budget_gb * 2**30 if args.mem_budget_gb
                       else min(ram_bytes() / 4, 6 * 2**30))
    args.max_file = args.max_file_gb * 2**30
    threads_before = edmf_rs.get_num_threads()

    print(f"Machine: {machine()}")
    print(f"best of {args.repeat}; float64 in memory up to {args.mem_budget / 2**30:.1f} GiB, else from a file; "
          f"worst = every instance a candidate, typical = 95 % falsified (iid residuals)\n")
    if not args.streaming_only:
        print(HEADER)
    with tempfile.TemporaryDirectory(prefix="edmf-bench-", dir=args.tmp) as tmp:
        for n in [] if args.streaming_only else args.n:
            for n_m in args.nm:
                for case in args.cases:
                    bench_case(n, n_m, case, args, Path(tmp))
        if not args.no_streaming:
            bench_streaming(args, Path(tmp))
    edmf_rs.set_num_threads(threads_before)
    return 0


if __name__ == "__main__":
    sys.exit(main())
