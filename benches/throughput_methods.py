"""What the throughput benchmark times, and the data it times them on.

The machine's description, the worst and typical problems (in memory or as a
.npy file written chunk by chunk), and every method of the table: the read
probes, the NumPy reference and rule (one-shot and chunked), the per-instance
Python loop and edmf_rs itself.
"""

from __future__ import annotations

import math
import os
import platform
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import edmf_rs
import numpy as np
from edmf_rs import Thresholds, reference

CHUNK_BYTES = 16 * 2**20  # NumPy chunked baselines read/compute this much at a time


# -- page cache ----------------------------------------------------------------

def evict(path: Path) -> None:
    """Drops the file from the page cache so the next read comes from disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
        os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
    finally:
        os.close(fd)


# -- machine -------------------------------------------------------------------

def machine() -> str:
    model, family = "unknown CPU", {}
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            key = key.strip()
            if key == "model name":
                model = value.strip()
            elif key in ("cpu family", "model"):
                family.setdefault(key, value.strip())
            if key == "processor" and family:
                break  # the first CPU's lines only
    except OSError:
        pass
    if family:  # the family and model tell CPU generations apart where the name does not
        model += f" (CPU family {family.get('cpu family', '?')}, model {family.get('model', '?')})"
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
        fh.writelines(rows(first, min(step, n - first), dtype).tobytes() for first in range(0, n, step))
    return y, t


# -- the methods -------------------------------------------------------------------

def read_floor(p, pool: ThreadPoolExecutor, k: int):
    """``np.max`` (vectorised, GIL released) over one slice per thread, at once."""
    return list(pool.map(np.max, [p[i * len(p) // k:(i + 1) * len(p) // k] for i in range(k)]))


def numpy_rule(p, y, t):
    r = p - y
    return np.all((r >= t.low) & (r <= t.high), axis=1)


def numpy_reference(p, y, t):
    return reference.falsify(p, y, t)


def in_chunks(p, method):
    step = max(1, CHUNK_BYTES // (p.shape[1] * p.itemsize))
    return [(i, method(p[i:i + step])) for i in range(0, p.shape[0], step)]


def numpy_chunked(p, y, t):
    return [np.flatnonzero(mask) + i for i, mask in in_chunks(p, lambda b: numpy_rule(b, y, t))]


def numpy_reference_chunked(p, y, t):
    return edmf_rs.concatenate([r for _, r in in_chunks(p, lambda b: numpy_reference(b, y, t))])


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


def file_numpy_reference(path, y, t):
    return edmf_rs.concatenate([numpy_reference(block, y, t) for _, block in file_chunks(path)])


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
