"""Throughput of edmf_rs.falsify against NumPy, in instances per second.

One run prints the machine and one table: for each N, n_m and case (worst:
every instance is a candidate, so no early exit; typical: over 90 % of the
instances are falsified), the rate of

- the memory-read probe ``np.sum`` over the same array (the floor: reading),
- the NumPy rule ``np.all((P - y >= lo) & (P - y <= hi), axis=1)``, one-shot
  and in chunks,
- a per-instance Python loop as EDMF scripts often do it (on a subset),
- ``edmf_rs.falsify`` with 1 and 2 threads, with and without diagnostics,

with ratios to the probe. Arrays that do not fit the memory budget are
streamed from a .npy file in a temporary folder (written in chunks; the
probe then reads the file in chunks with ``readinto``). A last table streams
an N x 16 float32 file (N = 10^8 by default) and measures the peak RSS of
the edmf_rs run in a subprocess.

    python benches/throughput.py --quick               # smoke run, a minute
    python benches/throughput.py --n 2000000 --nm 50   # one case
    python benches/throughput.py                       # everything (10^5..10^8: long, needs disk)

Timings are best-of-k with time.perf_counter; files are read warm (they
were just written, so they sit in the page cache when RAM allows); with
--cold the streaming case is also timed from disk (the file evicted from the
page cache with posix_fadvise before each run).
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import edmf_rs
import numpy as np
from edmf_rs import Thresholds

CHUNK_BYTES = 16 * 2**20  # NumPy chunked baselines read/compute this much at a time


# -- machine -------------------------------------------------------------------

def machine() -> str:
    model = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return (f"{model}; {cores} cores usable ({os.cpu_count()} online); RAM {ram_bytes() / 2**30:.1f} GiB; "
            f"{platform.system()} {platform.release()}; Python {platform.python_version()}, "
            f"NumPy {np.__version__}, edmf_rs {edmf_rs.__version__}")


def ram_bytes() -> int:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


# -- data ------------------------------------------------------------------------

def problem(n_m: int, case: str, seed: int = 0):
    """Measurements, thresholds, and a generator of prediction rows."""
    y = np.linspace(-1.0, 1.0, n_m)
    t = Thresholds(np.full(n_m, -1.0), np.full(n_m, 1.0))
    # typical: iid N(0, s) residuals with P(candidate) = 5 %: per sensor P(|r| <= 1) = 0.05**(1/n_m)
    p = 0.05 ** (1.0 / n_m)
    from scipy.special import erfinv

    sigma = 1.0 / (math.sqrt(2.0) * erfinv(p))

    def rows(first: int, count: int, dtype) -> np.ndarray:
        rng = np.random.default_rng([seed, first])
        if case == "worst":  # every residual inside the bounds: all candidates, every sensor visited
            r = rng.random((count, n_m), dtype=np.float32 if dtype == np.float32 else np.float64)
            r = r.astype(dtype, copy=False) * 1.98 - 0.99
        else:
            r = rng.standard_normal((count, n_m), dtype=np.float32 if dtype == np.float32 else np.float64)
            r = r.astype(dtype, copy=False) * sigma
        r += y
        return r.astype(dtype, copy=False)  # (NumPy scalars would promote float32 to float64)

    return y, t, rows


def in_memory(n: int, n_m: int, case: str, dtype) -> tuple:
    y, t, rows = problem(n_m, case)
    step = max(1, CHUNK_BYTES // (n_m * np.dtype(dtype).itemsize))
    out = np.empty((n, n_m), dtype=dtype)
    for first in range(0, n, step):
        out[first:first + step] = rows(first, min(step, n - first), dtype)
    return out, y, t


def to_file(path: Path, n: int, n_m: int, case: str, dtype) -> tuple:
    """Writes an (n, n_m) .npy file chunk by chunk (memory: one chunk)."""
    y, t, rows = problem(n_m, case)
    step = max(1, CHUNK_BYTES // (n_m * np.dtype(dtype).itemsize))
    with open(path, "wb") as fh:
        np.lib.format.write_array_header_2_0(
            fh, {"descr": np.lib.format.dtype_to_descr(np.dtype(dtype)), "fortran_order": False, "shape": (n, n_m)})
        for first in range(0, n, step):
            fh.write(rows(first, min(step, n - first), dtype).tobytes())
    return y, t


# -- the methods -------------------------------------------------------------------

def numpy_rule(p, y, t):
    r = p - y
    return np.all((r >= t.low) & (r <= t.high), axis=1)


def numpy_chunked(p, y, t):
    step = max(1, CHUNK_BYTES // (p.shape[1] * p.itemsize))
    return [np.flatnonzero(numpy_rule(p[i:i + step], y, t)) + i for i in range(0, p.shape[0], step)]


def python_loop(p, y, t):
    """One instance at a time, as EDMF scripts ported from MATLAB do it."""
    candidates = []
    for i in range(p.shape[0]):
        residual = p[i] - y
        if np.all((residual >= t.low) & (residual <= t.high)):
            candidates.append(i)
    return candidates


def file_chunks(path: Path):
    """Reads a C-ordered .npy file in chunks with readinto into one buffer."""
    with open(path, "rb", buffering=0) as fh:
        version = np.lib.format.read_magic(fh)
        read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                       else np.lib.format.read_array_header_2_0)
        shape, _, dtype = read_header(fh)
        step = max(1, CHUNK_BYTES // (shape[1] * dtype.itemsize))
        buf = np.empty((step, shape[1]), dtype=dtype)
        for first in range(0, shape[0], step):
            block = buf[:min(step, shape[0] - first)]
            view, done = memoryview(block).cast("B"), 0
            while done < view.nbytes:
                done += fh.readinto(view[done:])
            yield first, block


def file_read(path):
    for _ in file_chunks(path):
        pass


def file_numpy_rule(path, y, t):
    return [np.flatnonzero(numpy_rule(block, y, t)) + first for first, block in file_chunks(path)]


def edmf(source, y, t, threads, diagnostics):
    edmf_rs.set_num_threads(threads)
    return edmf_rs.falsify(source, y, t, diagnostics=diagnostics, keep_violations=False, progress=False)


def best(fn, repeat: int, setup=None) -> float:
    times = []
    for _ in range(repeat):
        if setup is not None:
            setup()
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
        if times[-1] > 20.0:  # long enough that more runs add little
            break
    return min(times)


# -- table -----------------------------------------------------------------------

HEADER = (f"{'N':>11} {'n_m':>4} {'case':>7} {'src':>4}  {'method':<34} {'time s':>8} {'inst/s':>10} "
          f"{'x probe':>8} {'x numpy':>8}")


def row(n, n_m, case, src, method, seconds, n_timed, probe_rate, numpy_rate=0.0):
    """One table line; ratios against the read probe and the NumPy rule (one-shot in
    memory, chunked for files), all measured in this run."""
    rate = n_timed / seconds if seconds else float("nan")
    ratio = rate / probe_rate if probe_rate else float("nan")
    vs_numpy = rate / numpy_rate if numpy_rate else float("nan")
    line = (f"{n:>11,} {n_m:>4} {case:>7} {src:>4}  {method:<34} {seconds:>8.3f} {rate:>10.3g} "
            f"{ratio:>8.2f} {vs_numpy:>8.1f}")
    print(line, flush=True)
    return rate


def skipped(n, n_m, case, src, method, why):
    print(f"{n:>11,} {n_m:>4} {case:>7} {src:>4}  {method:<34} {'-':>8} {'-':>10} {'-':>8}  ({why})", flush=True)


def bench_case(n, n_m, case, args, tmp: Path):
    dtype = np.float64
    nbytes = n * n_m * 8
    if nbytes <= args.mem_budget:
        p, y, t = in_memory(n, n_m, case, dtype)
        probe = row(n, n_m, case, "mem", "probe: np.sum", best(lambda: np.sum(p), args.repeat), n, 0)
        numpy = 0.0
        if 3.2 * nbytes <= args.mem_budget:
            numpy = row(n, n_m, case, "mem", "numpy rule, one-shot", best(lambda: numpy_rule(p, y, t), args.repeat),
                        n, probe)
        else:
            skipped(n, n_m, case, "mem", "numpy rule, one-shot", "temporaries exceed the memory budget")
        chunked = row(n, n_m, case, "mem", "numpy rule, chunked", best(lambda: numpy_chunked(p, y, t), args.repeat),
                      n, probe, numpy)
        numpy = numpy or chunked
        sub = p[:min(n, args.loop_n)]
        row(n, n_m, case, "mem", f"python loop ({len(sub):,} inst.)", best(lambda: python_loop(sub, y, t), 1),
            len(sub), probe, numpy)
        runs = [(th, d) for d in (True, False) for th in args.threads]
        for th, d in runs:
            row(n, n_m, case, "mem", f"edmf_rs {th} thr, diagnostics={d}",
                best(lambda th=th, d=d: edmf(p, y, t, th, d), args.repeat), n, probe, numpy)
        del p
        return
    if nbytes > args.max_file:
        skipped(n, n_m, case, "file", "all", f"{nbytes / 2**30:.0f} GiB file > --max-file-gb")
        return
    path = tmp / f"bench-{n}-{n_m}-{case}.npy"
    try:
        y, t = to_file(path, n, n_m, case, dtype)
        probe = row(n, n_m, case, "file", "probe: readinto chunks", best(lambda: file_read(path), args.repeat), n, 0)
        skipped(n, n_m, case, "file", "numpy rule, one-shot", "does not fit the memory budget")
        numpy = row(n, n_m, case, "file", "numpy rule, chunked (readinto)",
                    best(lambda: file_numpy_rule(path, y, t), args.repeat), n, probe)
        for d in (True, False):
            for th in args.threads:
                row(n, n_m, case, "file", f"edmf_rs {th} thr, diagnostics={d}",
                    best(lambda th=th, d=d: edmf(path, y, t, th, d), args.repeat), n, probe, numpy)
    finally:
        path.unlink(missing_ok=True)


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


def evict(path: Path) -> None:
    """Drops the file from the page cache so the next read comes from disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
        os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
    finally:
        os.close(fd)


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
        numpy = row(n, n_m, "typical", "file", "numpy rule, chunked (readinto)",
                    best(lambda: file_numpy_rule(path, y, t), args.repeat), n, probe)
        for d in (True, False):
            for th in args.threads:
                row(n, n_m, "typical", "file", f"edmf_rs {th} thr, diagnostics={d}",
                    best(lambda th=th, d=d: edmf(str(path), y, t, th, d), args.repeat), n, probe, numpy)
        # The kernel alone on the same data, in memory: the ceiling for streaming.
        m = min(n, 20_000_000)
        with open(path, "rb") as fh:
            np.lib.format.read_magic(fh)
            np.lib.format.read_array_header_2_0(fh)
            head = np.fromfile(fh, dtype=np.float32, count=m * n_m).reshape(m, n_m)
        th = max(args.threads)
        for d in (True, False):
            row(m, n_m, "typical", "mem", f"edmf_rs {th} thr, diagnostics={d}",
                best(lambda d=d: edmf(head, y, t, th, d), args.repeat), m, probe)
        del head
        if args.cold:
            def cold():
                evict(path)

            probe = row(n, n_m, "typical", "disk", "numpy readinto chunks (cold)",
                        best(lambda: file_read(path), args.repeat, cold), n, 0)
            for d in (True, False):
                th = max(args.threads)
                row(n, n_m, "typical", "disk", f"edmf_rs {th} thr, diagnostics={d} (cold)",
                    best(lambda th=th, d=d: edmf(str(path), y, t, th, d), args.repeat, cold), n, probe)
        base = peak_rss_mib("import-only")
        peak = peak_rss_mib(str(path))
        print(f"  peak RSS of a process running edmf_rs.falsify on the file: {peak:.0f} MiB "
              f"(of which {base:.0f} MiB just importing edmf_rs); the file is {path.stat().st_size / 2**20:,.0f} MiB")
    finally:
        path.unlink(missing_ok=True)


def main(argv=None) -> int:
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
    ap.add_argument("--max-file-gb", type=float, default=16.0, help="skip file cases larger than this")
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
