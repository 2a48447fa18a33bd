"""What the checkpoint's row digest costs beside the falsification it guards.

A checkpointed run feeds every chunk to the Rust falsifier and then to the
Rust row digest (xxh3, parallel over 1024-instance leaves). This times the
same chunks through the falsifier alone ("hash off") and falsifier + digest
("hash on"), interleaved in one run, best of several repeats, and prints the
ratio; then the same for ``falsify`` over a warm ``.npy`` file with a
checkpoint folder (rows "file+ckpt"), where "hash off" replaces the digest
by a stub that only counts rows. Run: ``python benches/hash_cost.py [rows] [sensors]``.
"""

from __future__ import annotations

import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import edmf_rs
from edmf_rs import _core
from edmf_rs.stream import checkpoint
from edmf_rs.stream.npy import CHUNK_BYTES


class NoDigest:
    """Counts rows like ``_core.RowDigest`` but hashes nothing ("hash off")."""

    block_rows = _core.RowDigest.block_rows

    def __init__(self):
        self.n_rows, self.n_blocks = 0, 0

    def update(self, rows):
        self.n_rows += len(rows)

    def blocks(self, start=0):
        return ["0" * 32] * (self.n_rows // self.block_rows - start)

    def partial(self):
        return "0" * 32 if self.n_rows % self.block_rows else None


def checkpointed_file_run(path: Path, y, low, high, digest: bool) -> float:
    """``falsify`` over a ``.npy`` file with a checkpoint folder, as a user runs it."""
    original = checkpoint._core
    folder = Path(tempfile.mkdtemp(prefix="edmf-hash-cost-"))
    try:
        if not digest:
            checkpoint._core = type("Core", (), {"RowDigest": NoDigest})
        start = time.perf_counter()
        edmf_rs.falsify(path, y, edmf_rs.Thresholds(low, high), checkpoint=folder / "run", progress=False)
        return time.perf_counter() - start
    finally:
        checkpoint._core = original
        shutil.rmtree(folder, ignore_errors=True)


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
        with tempfile.TemporaryDirectory() as tmp:  # end to end: a checkpointed run over a warm .npy file
            path = Path(tmp) / "p.npy"
            np.save(path, data)
            off, on = [], []
            for _ in range(repeats):
                off.append(checkpointed_file_run(path, y, low, high, False))
                on.append(checkpointed_file_run(path, y, low, high, True))
            o, h = min(off), min(on)
            print(f"{np.dtype(dtype).name:8} {'file+ckpt':12} {o:12.3f} {h:12.3f} {h / o:8.3f} {data.nbytes / o / 1e9:9.2f}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
