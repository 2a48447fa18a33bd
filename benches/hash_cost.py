"""What the checkpoint's block checksum costs beside the falsification it guards.

A checkpointed run sums every row it falsifies into the block checksum
``fletcher64x8/2`` (``rust/src/digest.rs``), in the falsifier's own pass
(``Falsifier.update(chunk, digest=...)``, ``rust/src/summing.rs``): the
periodic kernel (short rows, at AVX-512 and AVX2) adds each vector it loads
to the sums as it compares it, and the kernels that read a row (or sixteen)
at a time add each 64-byte group once the rows read so far fill it, from
L1; rows the vector kernels do not sum (not stored back to back, the
portable level) are summed 128 KiB at a time by the thread that has just
screened them, while they are in that core's L2 cache. ``EDMF_RS_ISA=avx2``
runs it at AVX2. This times, side by side in one run, the same in-memory chunks through

- "off": the falsifier alone;
- "on":  the falsifier feeding the checksum (what a checkpointed run does);

for float64 and float32, n_m in {5, 10, 16, 50}, the worst case (every instance a
candidate: no early exit) and the typical one (95 % falsified, iid residuals),
screening (``diagnostics=False``, the fastest pass, so the checksum's largest
share) and diagnostics. The two variants alternate in every round; the table
gives the best CPU time (``time.process_time``: all threads of the process)
and wall time of each, the CPU and wall ratios on/off of the best times, and
the median over rounds of the paired CPU ratio (the most robust figure on a
shared machine). Target: on/off below 1.05.

What bounds it (``cargo bench --bench checksum`` times both on the same
bytes, one thread; ``results-checksum.txt``): the checksum must read every
byte (a 64-byte load and five vector operations per 64 bytes, float64 or
float32 alike: the values' bits are summed at their stored width), faster
than the screening kernel reads the same bytes and faster than XXH3-128
(``results-checksum.txt``), whether the data are in cache or in memory: the kernel is not
waiting on memory, so there is no idle time to hide the sums in, and summing
what it has just read adds to its CPU time (the first table).

The last two tables are the streaming rate the checksum is meant to be
cheap beside: ``edmf_rs.falsify`` over a ``.npy`` file with no checkpoint,
with a checkpoint folder whose checksum is replaced by a row counter
(`RowCounter`), and with a real one, wall time, rounds in rotating order.
"sum share" (real / counter, best times) is the checksum's cost, "paired"
the median over rounds of the same ratio within a round (the two runs a
few tenths of a second apart: steadier on a shared host); "ckpt/none" what
the rest of a checkpoint costs. The file is read warm (in the page cache, as
after it was written: the copy out of the page cache is then most of the
CPU time, the hardest case for the checksum) and cold (its pages dropped
with ``posix_fadvise(POSIX_FADV_DONTNEED)`` before every run: read from the
disk, as a file larger than the memory always is).

Run: ``python benches/hash_cost.py`` (about seven minutes; ``--mbytes`` sets
the data per in-memory case, ``--file-mbytes`` per file, ``--repeats`` and
``--cold-repeats`` the rounds).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import platform
import statistics
import shutil
import subprocess
import tempfile
import time
import types
from pathlib import Path

import edmf_rs
import numpy as np
from edmf_rs import _core
from edmf_rs.stream.npy import CHUNK_BYTES
from scipy.special import erfinv
from throughput_methods import evict  # beside this script


def cpu_model() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
        return next(line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("Model name"))
    except (OSError, StopIteration):
        return platform.processor() or "unknown"


def load() -> str:
    try:
        return "load average %.2f %.2f %.2f" % os.getloadavg()
    except OSError:
        return "load unknown"


def problem(n: int, n_m: int, case: str, dtype, seed: int = 0):
    """Measurements, bounds and chunks of predictions (as ``falsify`` cuts them)."""
    rng = np.random.default_rng(seed)
    y = np.linspace(-1.0, 1.0, n_m)
    if case == "worst":  # every residual inside the bounds: all candidates, every sensor visited
        r = rng.random((n, n_m), dtype=np.float64) * 1.98 - 0.99
    else:  # iid N(0, s) residuals with P(candidate) = 5 %: per sensor P(|r| <= 1) = 0.05**(1/n_m)
        r = rng.standard_normal((n, n_m)) / (math.sqrt(2.0) * erfinv(0.05 ** (1.0 / n_m)))
    data = (r + y).astype(dtype)
    step = max(1024, CHUNK_BYTES // (n_m * data.itemsize))
    return y, [data[i:i + step] for i in range(0, n, step)]


def run(chunks, y, diagnostics: bool, checksum: bool) -> tuple[float, float]:
    """(CPU seconds of the whole process, wall seconds) of one pass."""
    n_m = len(y)
    acc = _core.Falsifier(y, np.full(n_m, -1.0), np.full(n_m, 1.0), diagnostics=diagnostics,
                          keep_violations=False)
    digest = _core.RowDigest() if checksum else None
    cpu, wall = time.process_time(), time.perf_counter()
    for c in chunks:
        acc.update(c, digest=digest)
    return time.process_time() - cpu, time.perf_counter() - wall


class RowCounter:
    """Stands in for ``_core.RowDigest`` in a checkpoint to time one without
    the checksum: counts rows, sums nothing (its folders are never resumed)."""

    algorithm, block_rows = _core.RowDigest.algorithm, _core.RowDigest.block_rows

    def __init__(self):
        self.n_rows, self.n_blocks = 0, 0

    def update(self, rows) -> None:
        self.n_rows += len(rows)

    def blocks(self, start: int = 0) -> list:
        return []

    def partial(self):
        return None


@contextlib.contextmanager
def checksum_off():
    """Checkpointed runs with the checksum replaced by `RowCounter`."""
    from edmf_rs.engine import durable
    from edmf_rs.stream import checkpoint
    saved = checkpoint._core, durable.Durable.in_pass
    checkpoint._core = types.SimpleNamespace(RowDigest=RowCounter)
    durable.Durable.in_pass = False  # the falsifier gets no digest; `done` feeds the counter
    try:
        yield
    finally:
        checkpoint._core, durable.Durable.in_pass = saved


def stream(path: Path, y, diagnostics: bool, folder: Path | None, checksum: bool = True) -> float:
    """Wall seconds of one ``falsify`` over the file, checkpointed into ``folder`` if given."""
    if folder is not None:
        shutil.rmtree(folder, ignore_errors=True)
    n_m = len(y)
    t = edmf_rs.Thresholds(np.full(n_m, -1.0), np.full(n_m, 1.0))
    with contextlib.nullcontext() if checksum else checksum_off():
        wall = time.perf_counter()
        edmf_rs.falsify(str(path), y, t, diagnostics=diagnostics, progress=False, checkpoint=folder)
        return time.perf_counter() - wall


def streaming_table(args, cold: bool) -> list[float]:
    """On/off wall ratios of checkpointed file streaming (see the module docs)."""
    repeats = args.cold_repeats if cold else args.repeats
    print(f"\nStreaming {args.file_mbytes} MB per case from a .npy file ({'cold: read from the disk' if cold else 'warm'}): "
          f"no checkpoint (none), a checkpoint "
          f"folder with the checksum replaced by a row counter (ckpt), and a real checkpoint (ckpt+sum); wall s, "
          f"best of {repeats} rounds in rotating order; {load()}")
    head = (f"{'dtype':7} {'n_m':>3} {'case':7} {'pass':11} {'none':>7} {'ckpt':>7} {'ckpt+sum':>8} "
            f"{'sum share':>9} {'ckpt/none':>9} {'GB/s none':>9} {'paired':>7}")
    print(head)
    print("-" * len(head))
    ratios, paired_medians = [], []
    variants = {"none": (False, True), "ckpt": (True, False), "ckpt+sum": (True, True)}
    with tempfile.TemporaryDirectory(prefix="edmf-hash-cost-") as tmp:
        path, folder = Path(tmp) / "g.npy", Path(tmp) / "ckpt"
        for dtype in (np.float64, np.float32):
            for n_m in args.nm:
                for case in ("worst", "typical"):
                    n = args.file_mbytes * 10**6 // (n_m * np.dtype(dtype).itemsize)
                    y, chunks = problem(n, n_m, case, dtype)
                    out = np.lib.format.open_memmap(path, mode="w+", dtype=dtype, shape=(n, n_m))
                    first = 0
                    for c in chunks:
                        out[first:first + len(c)] = c
                        first += len(c)
                    out.flush()
                    del out, chunks
                    for diagnostics in (False, True):
                        stream(path, y, diagnostics, folder)  # warm
                        times = {v: [] for v in variants}
                        order = list(variants)
                        for k in range(repeats):
                            for v in order[k % 3:] + order[:k % 3]:
                                ckpt, summed = variants[v]
                                if cold:
                                    evict(path)
                                times[v].append(stream(path, y, diagnostics, folder if ckpt else None, summed))
                        best_of = {v: min(t) for v, t in times.items()}
                        share = best_of["ckpt+sum"] / best_of["ckpt"]
                        ratios.append(share)
                        # Each round's two checkpointed runs, a few tenths of a second apart.
                        paired = statistics.median(a / b for a, b in zip(times["ckpt+sum"], times["ckpt"]))
                        paired_medians.append(paired)
                        print(f"{np.dtype(dtype).name:7} {n_m:3d} {case:7} "
                              f"{'diagnostics' if diagnostics else 'screen':11} {best_of['none']:7.3f} "
                              f"{best_of['ckpt']:7.3f} {best_of['ckpt+sum']:8.3f} {share:9.3f} "
                              f"{best_of['ckpt'] / best_of['none']:9.3f} "
                              f"{args.file_mbytes / 1e3 / best_of['none']:9.2f} {paired:7.3f}", flush=True)
    print(f"streaming {'cold' if cold else 'warm'}, ckpt+sum / ckpt: median {statistics.median(ratios):.3f}, "
          f"largest {max(ratios):.3f}; median of the paired ratios {statistics.median(paired_medians):.3f}; "
          f"after: {load()}")
    return ratios


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mbytes", type=int, default=96, help="data per case, MB (default 96, above the L3 cache)")
    ap.add_argument("--repeats", type=int, default=9, help="alternating rounds per case (default 9)")
    ap.add_argument("--file-mbytes", type=int, default=1000, help="data per streamed file, MB (default 1000)")
    ap.add_argument("--cold-repeats", type=int, default=5, help="rounds per cold streaming case (default 5)")
    ap.add_argument("--nm", type=int, nargs="+", default=[5, 10, 16, 50])
    args = ap.parse_args(argv)
    start = time.perf_counter()
    print(f"CPU: {cpu_model()}; {_core.get_num_threads()} threads; {load()}")
    print(f"{args.mbytes} MB of predictions per case, in memory, chunks of {CHUNK_BYTES >> 20} MiB; "
          f"best of {args.repeats} alternating rounds")
    head = (f"{'dtype':7} {'n_m':>3} {'case':7} {'pass':11} {'CPU off':>8} {'CPU on':>8} {'CPU on/off':>10} "
            f"{'median':>7} {'wall off':>8} {'wall on':>8} {'wall on/off':>11} {'GB/s off':>8}")
    print(head)
    print("-" * len(head))
    ratios = []
    for dtype in (np.float64, np.float32):
        for n_m in args.nm:
            for case in ("worst", "typical"):
                n = args.mbytes * 10**6 // (n_m * np.dtype(dtype).itemsize)
                y, chunks = problem(n, n_m, case, dtype)
                for diagnostics in (False, True):
                    run(chunks, y, diagnostics, True)  # warm: pages, pool, screening plan
                    times = {False: [], True: []}
                    for k in range(args.repeats):
                        for on in ((False, True) if k % 2 == 0 else (True, False)):
                            times[on].append(run(chunks, y, diagnostics, on))
                    cpu = {on: min(t[0] for t in times[on]) for on in times}
                    wall = {on: min(t[1] for t in times[on]) for on in times}
                    paired = statistics.median(a[0] / b[0] for a, b in zip(times[True], times[False]))
                    ratios.append(cpu[True] / cpu[False])
                    print(f"{np.dtype(dtype).name:7} {n_m:3d} {case:7} {'diagnostics' if diagnostics else 'screen':11} "
                          f"{cpu[False]:8.3f} {cpu[True]:8.3f} {cpu[True] / cpu[False]:10.3f} {paired:7.3f} "
                          f"{wall[False]:8.3f} {wall[True]:8.3f} {wall[True] / wall[False]:11.3f} "
                          f"{args.mbytes / 1e3 / wall[False]:8.2f}", flush=True)
    print(f"CPU on/off of the best times: median {statistics.median(ratios):.3f}, "
          f"largest {max(ratios):.3f}; after: {load()}")
    if args.file_mbytes > 0:
        streaming_table(args, cold=False)
        streaming_table(args, cold=True)
    print(f"{time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
