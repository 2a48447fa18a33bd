"""Two builds of edmf_rs side by side in one process, against the read floor.

Each build is an installed ``edmf_rs`` package folder (``site-packages/edmf_rs``
of a venv); both are copied into a temporary folder under other names and
imported together (the package's own imports are relative, and its Rust
extension's init function is named after its file, so it loads under any
package name). Every round then runs the floor (``np.max`` over the two halves
on two threads at once) and ``falsify`` of each build on the same array, in a
rotating order, so a slow spell of a shared host falls on all three alike.
Per case the line gives each build's speed / floor (best of the rounds, and
the median over rounds of the ratio within a round) and the median over rounds
of time(old) / time(new): above 1, the new build is faster.

    python benches/paired_builds.py OLD_SITE/edmf_rs NEW_SITE/edmf_rs
    python benches/paired_builds.py OLD NEW --nm 10 50 --dtype f64 --repeat 25
"""

from __future__ import annotations

import argparse
import importlib
import shutil
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from throughput_methods import in_memory, machine


def load(folder: Path, name: str, into: Path):
    """The package in `folder` imported as `name` (copied into `into`)."""
    if not (folder / "__init__.py").is_file():
        raise SystemExit(f"{folder}: expected an installed edmf_rs package folder (with __init__.py)")
    shutil.copytree(folder, into / name, ignore=shutil.ignore_patterns("__pycache__"))
    return importlib.import_module(name)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("old", type=Path, help="the old build's edmf_rs package folder")
    ap.add_argument("new", type=Path, help="the new build's edmf_rs package folder")
    ap.add_argument("--nm", type=int, nargs="+", default=[5, 10, 16, 50, 200])
    ap.add_argument("--dtype", nargs="+", default=["f64", "f32"], choices=["f64", "f32"])
    ap.add_argument("--cases", nargs="+", default=["worst", "typical"], choices=["worst", "typical"])
    ap.add_argument("--mode", nargs="+", default=["diag"], choices=["diag", "scr"],
                    help="diagnostics=True (diag) and/or False (scr)")
    ap.add_argument("--mb", type=float, default=800.0, help="array size in MB")
    ap.add_argument("--repeat", type=int, default=15, help="rounds per case")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        sys.path.insert(0, tmp)
        old = load(args.old.resolve(), "edmf_rs_old_build", Path(tmp))
        new = load(args.new.resolve(), "edmf_rs_new_build", Path(tmp))
        print(machine())
        # The builds by version, not by path: results files keep no machine's paths.
        prefetch = {b: getattr(b._core, "prefetch", lambda: "t1:8192")() for b in (old, new)}
        print(f"old: edmf_rs {old.__version__}, prefetch {prefetch[old]}; new: edmf_rs {new.__version__}, "
              f"prefetch {prefetch[new]}; {old.get_num_threads()} threads")
        gains = []
        with ThreadPoolExecutor(2) as pool:
            for n_m in args.nm:
                for dt in args.dtype:
                    dtype = np.float64 if dt == "f64" else np.float32
                    n = int(args.mb * 1e6) // (n_m * np.dtype(dtype).itemsize)
                    for case in args.cases:
                        p, y, t = in_memory(n, n_m, case, dtype)
                        halves = (p[: n // 2], p[n // 2:])
                        for mode in args.mode:
                            kw = dict(diagnostics=mode == "diag", keep_violations=False, progress=False)
                            t_old, t_new = (b.Thresholds(t.low, t.high) for b in (old, new))
                            a, b = old.falsify(p, y, t_old, **kw), new.falsify(p, y, t_new, **kw)
                            assert a.n_candidates == b.n_candidates, (n_m, dt, case, mode)
                            fns = {"floor": lambda: list(pool.map(np.max, halves)),
                                   "old": lambda: old.falsify(p, y, t_old, **kw),
                                   "new": lambda: new.falsify(p, y, t_new, **kw)}
                            times = {k: [] for k in fns}
                            names = list(fns)
                            for r in range(args.repeat):
                                for k in names[r % 3:] + names[:r % 3]:
                                    s = time.perf_counter()
                                    fns[k]()
                                    times[k].append(time.perf_counter() - s)
                            f, o, w = (np.array(times[k]) for k in names)
                            gains.append(float(np.median(o / w)))
                            print(f"{n_m:>4} {dt} {case:>7} {mode:>4}  floor {f.min() * 1e3:6.1f} ms | "
                                  f"old/floor {f.min() / o.min():.2f} (paired {np.median(f / o):.2f}) | "
                                  f"new/floor {f.min() / w.min():.2f} (paired {np.median(f / w):.2f}) | "
                                  f"old/new paired {gains[-1]:.3f}", flush=True)
                        del p, halves
        print(f"old/new paired, median over {len(gains)} cases: {np.median(gains):.3f} "
              f"(range {min(gains):.3f}-{max(gains):.3f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
