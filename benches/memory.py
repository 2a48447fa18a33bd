"""Peak memory of ``edmf-rs run`` against the number of instances (issue 14, part 5).

The shipped cantilever project (``examples/projects/cantilever.toml``: 10
sensors, scenario 2, a ``[[prognosis]]``) with its grid replaced by Sobol'
sampling of 2^k instances; about 58 % of them are candidates. Each run is a
separate ``python -m edmf_rs run`` process; its peak resident set size is that
child's ``ru_maxrss`` from ``os.wait4`` (the kernel's high-water mark of the
process, file-backed pages included). The candidates stream to
``candidates.parquet``, so the peak should not grow with N nor with the number
of candidates. Also printed: the candidate count, the wall time and the size
of candidates.parquet.

Run: ``python benches/memory.py`` (2^19, 2^21, 2^23; pass exponents to
change them, e.g. ``python benches/memory.py 16 18``). The 2^23 run writes
about 1 GB (the prediction store and candidates.parquet) into a temporary
folder, removed afterwards.
"""

from __future__ import annotations

import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "python" / "edmf_rs" / "examples" / "projects"


def cantilever_project(folder: Path, n: int, store: bool = True) -> Path:
    """The shipped cantilever project in ``folder`` with ``n`` Sobol' instances instead of its grid."""
    for name in ("cantilever.csv", "cantilever_model.py"):
        shutil.copy(EXAMPLES / name, folder / name)
    text = (EXAMPLES / "cantilever.toml").read_text(encoding="utf-8")
    text, count = re.subn(r'method = "grid"\npoints = \{ E = 101 \}[^\n]*\n',
                          f'method = "sobol"\nn = {n}\nseed = 0\n', text)
    assert count == 1, "cantilever.toml changed: update benches/memory.py"
    if not store:
        text = text.replace('path = "."', 'path = "."\nstore = false', 1)
    path = folder / "cantilever.toml"
    path.write_text(text, encoding="utf-8")
    return path


def run_measured(args: list[str], cwd: Path) -> tuple[int, float, int, str]:
    """(exit status, seconds, peak RSS in bytes, stderr) of one child process."""
    started = time.perf_counter()
    with tempfile.TemporaryFile() as err:
        child = subprocess.Popen(args, cwd=cwd, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(child.pid, 0)
        child.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        text = err.read().decode(errors="replace")
    return child.returncode, time.perf_counter() - started, usage.ru_maxrss * 1024, text  # maxrss: KiB on Linux


def measure(k: int, store: bool = True) -> dict:
    """Runs the cantilever with 2^k instances; returns its counts and peak RSS."""
    with tempfile.TemporaryDirectory(prefix="edmf-rs-memory-") as tmp:
        folder = Path(tmp)
        project = cantilever_project(folder, 2**k, store=store)
        out = folder / "out"
        status, seconds, peak, err = run_measured(
            [sys.executable, "-m", "edmf_rs", "run", str(project), "--out", str(out), "--no-progress", "--yes"],
            folder)
        if status != 0:
            raise SystemExit(f"2^{k}: edmf-rs run exited with {status}:\n{err}")
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
        return {"k": k, "instances": summary["instances"], "candidates": summary["candidates"],
                "peak_rss_mb": peak / 2**20, "seconds": seconds,
                "parquet_mb": (out / "candidates.parquet").stat().st_size / 2**20}


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def main(argv: list[str]) -> None:
    exponents = [int(a) for a in argv] or [19, 21, 23]
    print(f"CPU: {cpu_model()} ({os.cpu_count()} logical cores), Python {platform.python_version()}")
    print("edmf-rs run, cantilever (10 sensors, 1 prognosis), Sobol' instances, prediction store on")
    print(f"{'instances':>12} {'candidates':>12} {'peak RSS MB':>12} {'seconds':>9} {'parquet MB':>11}")
    for k in exponents:
        row = measure(k)
        print(f"{row['instances']:>12,} {row['candidates']:>12,} {row['peak_rss_mb']:>12.1f} "
              f"{row['seconds']:>9.1f} {row['parquet_mb']:>11.1f}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
