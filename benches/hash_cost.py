"""What the checkpoint's row digest costs beside the falsification it guards.

A checkpointed run feeds every chunk to the Rust falsifier and then to the
Rust row digest (xxh3, parallel over 1024-instance leaves). This times the
same chunks through the falsifier alone ("hash off") and falsifier + digest
("hash on"), interleaved in one run, best of several repeats, and prints the
ratio. Run: ``python benches/hash_cost.py [rows] [sensors]``.
"""

from __future__ import annotations

import platform
import subprocess
import sys
import time

import numpy as np
from edmf_rs import _core
from edmf_rs.stream.npy import CHUNK_BYTES


def cpu_model() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
        return next(line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("Model name"))
    except (OSError, StopIteration):
        return platform.processor() or "unknown"


def run(chunks, y, low, high, digest: bool, diagnostics: bool) -> float:
    start = time.perf_counter()
    acc = _core.Falsifier(y, low, high, diagnostics=diagnostics, keep_violations=False)
    rows = _core.RowDigest() if digest else None
    for c in chunks:
        acc.update(c)
        if rows is not None:
            rows.update(c)
    return time.perf_counter() - start


def main(n: int = 2_000_000, m: int = 50, repeats: int = 5) -> None:
    rng = np.random.default_rng(0)
    y, low, high = np.zeros(m), np.full(m, -2.5), np.full(m, 2.5)
    print(f"CPU: {cpu_model()}; threads: {_core.get_num_threads()}; {n:,} instances x {m} sensors")
    print(f"{'dtype':8} {'mode':12} {'hash off (s)':>12} {'hash on (s)':>12} {'on/off':>8} {'GB/s off':>9}")
    for dtype in (np.float64, np.float32):
        data = rng.normal(size=(n, m)).astype(dtype)
        step = max(1024, CHUNK_BYTES // (m * data.itemsize))
        chunks = [data[i:i + step] for i in range(0, n, step)]
        for diagnostics in (False, True):
            off, on = [], []
            for _ in range(repeats):  # interleaved, so drift hits both alike
                off.append(run(chunks, y, low, high, False, diagnostics))
                on.append(run(chunks, y, low, high, True, diagnostics))
            o, h = min(off), min(on)
            mode = "diagnostics" if diagnostics else "screen"
            print(f"{np.dtype(dtype).name:8} {mode:12} {o:12.3f} {h:12.3f} {h / o:8.3f} {data.nbytes / o / 1e9:9.2f}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
