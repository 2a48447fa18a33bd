"""What the checkpoint's row digest costs beside the falsification it guards.

A checkpointed run hashes every row it falsifies (xxh3 over 1024-instance
leaves, see ``rust/src/digest.rs``). The falsifier does it in the same pass
(``Falsifier.update(chunk, digest=...)``): each leaf is hashed by the task
that has just screened it, while its rows are in that core's cache. This
times the same chunks through

- "off":      the falsifier alone;
- "in-pass":  the falsifier feeding the digest in its own pass (what a
  checkpointed run does);
- "separate": the falsifier, then a second ``RowDigest`` pass per chunk (the
  former way, for comparison);

then ``falsify`` over a warm ``.npy`` file with and without a checkpoint
folder ("file"). The machine may be shared: times are process CPU time
(``time.process_time``, all threads) and wall time, best of several
alternating repeats; ratios are against "off" measured in the same round.
Run: ``python benches/hash_cost.py [rows] [sensors] [repeats]``.
"""

from __future__ import annotations

import os
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
from edmf_rs.stream.npy import CHUNK_BYTES


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


def timed(work) -> tuple[float, float]:
    """(CPU seconds of the whole process, wall seconds) of ``work()``."""
    cpu, wall = time.process_time(), time.perf_counter()
    work()
    return time.process_time() - cpu, time.perf_counter() - wall


def chunks_run(chunks, y, low, high, how: str, diagnostics: bool):
    def work():
        acc = _core.Falsifier(y, low, high, diagnostics=diagnostics, keep_violations=False)
        rows = _core.RowDigest()
        for c in chunks:
            if how == "in-pass":
                acc.update(c, digest=rows)
            else:
                acc.update(c)
                if how == "separate":
                    rows.update(c)
    return work


def file_run(path: Path, y, low, high, checkpoint: bool):
    def work():
        folder = Path(tempfile.mkdtemp(prefix="edmf-hash-cost-"))
        try:
            edmf_rs.falsify(path, y, edmf_rs.Thresholds(low, high), progress=False,
                            checkpoint=folder / "run" if checkpoint else None, checkpoint_every=3600)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
    return work


def compare(label: str, works: dict, repeats: int, nbytes: int) -> None:
    """Alternates the variants ``repeats`` times; prints best CPU and wall times."""
    cpu = {k: [] for k in works}
    wall = {k: [] for k in works}
    for _ in range(repeats):
        for k, w in works.items():
            c, t = timed(w)
            cpu[k].append(c)
            wall[k].append(t)
    base = next(iter(works))
    for k in works:
        c, t = min(cpu[k]), min(wall[k])
        print(f"{label:22} {k:9} {c:9.3f} {c / min(cpu[base]):8.3f} {t:9.3f} {t / min(wall[base]):8.3f}"
              f" {nbytes / t / 1e9:8.2f}")


def main(n: int = 2_000_000, m: int = 50, repeats: int = 5) -> None:
    rng = np.random.default_rng(0)
    y, low, high = np.zeros(m), np.full(m, -2.5), np.full(m, 2.5)
    print(f"CPU: {cpu_model()}; threads: {_core.get_num_threads()}; {load()}")
    print(f"{n:,} instances x {m} sensors; best of {repeats} alternating repeats")
    print(f"{'case':22} {'variant':9} {'CPU (s)':>9} {'CPU/off':>8} {'wall (s)':>9} {'wall/off':>8} {'GB/s':>8}")
    for dtype in (np.float64, np.float32):
        data = rng.normal(size=(n, m)).astype(dtype)
        step = max(1024, CHUNK_BYTES // (m * data.itemsize))
        chunks = [data[i:i + step] for i in range(0, n, step)]
        name = np.dtype(dtype).name
        for diagnostics in (False, True):
            mode = "diagnostics" if diagnostics else "screen"
            compare(f"{name} {mode}", {how: chunks_run(chunks, y, low, high, how, diagnostics)
                                       for how in ("off", "in-pass", "separate")}, repeats, data.nbytes)
        with tempfile.TemporaryDirectory() as tmp:  # end to end: falsify over a warm .npy file
            path = Path(tmp) / "p.npy"
            np.save(path, data)
            compare(f"{name} file diagnostics", {"off": file_run(path, y, low, high, False),
                                            "in-pass": file_run(path, y, low, high, True)},
                    repeats, data.nbytes)
    print(f"after: {load()}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:4]))
