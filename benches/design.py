"""Measurement-system design (edmf_rs.design) against its NumPy reference,
side by side in one run.

- greedy placement, N instances x L locations, k sensors: edmf_rs time, and
  time per evaluated (step, location) pair against the NumPy reference's time
  per pair (H(S + {i}) by ``np.unique`` over the rows, measured on a sample
  of pairs at |S| = 0, k/2 and k - 1);
- expected identifiability: n_sim simulations on k sensors, edmf_rs against
  the NumPy reference per simulation (on a subset of simulations);
- the whole curve k = 1..K;
- with --big: placement on an N x L float32 .npy memory map (no copy), with
  the peak RSS of the process.

    python benches/design.py --quick       # smoke run
    python benches/design.py               # issue targets: N=10^5, L=500, k=20
    python benches/design.py --big 1000000 1000

Timings are best-of-1 wall clock (time.perf_counter) with the process CPU
time (all threads); the CPU model, the thread count and the load average
are printed with them, and the run ends with the issue's targets table.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import stats

import edmf_rs
from edmf_rs import design
from edmf_rs.design import reference as ref


def cpu_model() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
        return next(line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("Model name"))
    except Exception:
        return platform.processor() or "unknown"


def predictions(n: int, n_loc: int, seed: int = 0, dtype=np.float64) -> np.ndarray:
    """A smooth 3-parameter response along a beam (plus a little noise): many near-ties."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.5, 1.5, size=(n, 3))
    x = np.linspace(0, 1, n_loc)
    g = (theta[:, :1] * np.sin(np.pi * x) + theta[:, 1:2] * x**2 + theta[:, 2:3] * np.cos(3 * x))
    g += 0.002 * rng.standard_normal(size=g.shape)
    return g.astype(dtype)


CPU_TIMES: list[float] = []


def timed(f):
    """Wall time of f() (and its process CPU time, kept in CPU_TIMES: the machine may be shared)."""
    c, t = time.process_time(), time.perf_counter()
    out = f()
    CPU_TIMES.append(time.process_time() - c)
    return time.perf_counter() - t, out


def bench_placement(g, widths, k, pairs_per_size=3):
    """Lazy greedy (the default) and plain greedy (every remaining location at
    every step: the per-pair comparison with the reference) side by side."""
    t_rust, d = timed(lambda: design.place_sensors(g, widths, k))
    t_plain, plain = timed(lambda: design.place_sensors(g, widths, k, lazy=False))
    assert plain.order.tolist() == d.order.tolist(), "lazy and plain greedy disagree"
    per_pair_rust = t_plain / plain.evaluations
    order = d.order.tolist()
    b = ref.bins(g, widths)
    samples = []
    for size in sorted({0, k // 2, k - 1}):
        s = order[:size]
        others = [i for i in range(g.shape[1]) if i not in s][:pairs_per_size]
        t, _ = timed(lambda: [ref.entropy_of_tuples(b[:, s + [i]]) for i in others])
        samples.append(t / len(others))
    per_pair_ref = float(np.mean(samples))
    return t_rust, d, t_plain, plain, per_pair_rust, per_pair_ref


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--locations", type=int, default=500)
    ap.add_argument("--k", type=int, default=20)
    ap.add_argument("--sims", type=int, default=1000)
    ap.add_argument("--ref-sims", type=int, default=20, help="simulations timed for the NumPy reference")
    ap.add_argument("--quick", action="store_true", help="N=10^4, L=100, k=10, 200 simulations")
    ap.add_argument("--big", nargs=2, type=int, metavar=("N", "L"), help="also place on an N x L float32 memory map")
    a = ap.parse_args(argv)
    if a.quick:
        a.n, a.locations, a.k, a.sims, a.ref_sims = 10_000, 100, 10, 200, 10
    print(f"CPU: {cpu_model()}; edmf_rs threads: {edmf_rs.get_num_threads()}; "
          f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    g = predictions(a.n, a.locations)
    sd = np.full(a.locations, 0.01)
    combined = edmf_rs.combine(measurement=[stats.norm(0, sd)])
    widths = design.interval_widths(combined, a.k)
    print(f"\nGreedy placement: N={a.n}, L={a.locations}, k={a.k}, float64")
    t_rust, d, t_plain, plain, pp_rust, pp_ref = bench_placement(g, widths, a.k)
    cpu_rust, cpu_plain = CPU_TIMES[0], CPU_TIMES[1]
    print(f"  edmf_rs lazy greedy: {t_rust:.3f} s wall, {cpu_rust:.3f} s CPU (all threads), {d.evaluations} "
          f"(step, location) pairs evaluated, H = {d.joint_entropy[-1]:.3f} bits")
    print(f"  edmf_rs plain greedy: {t_plain:.3f} s wall, {cpu_plain:.3f} s CPU, {plain.evaluations} pairs "
          "(same order)")
    print(f"  per pair (plain greedy): edmf_rs {pp_rust * 1e3:.3f} ms, NumPy reference {pp_ref * 1e3:.3f} ms "
          f"-> {pp_ref / pp_rust:.0f}x")
    print(f"  whole greedy run, NumPy reference (estimated k x L pairs): {pp_ref * a.k * a.locations:.0f} s "
          f"-> {pp_ref * a.k * a.locations / t_rust:.0f}x the lazy run")

    order = d.order.tolist()
    print(f"\nExpected identifiability: {a.sims} simulations, N={a.n}, {a.k} sensors")
    t_ei, r = timed(lambda: design.expected_identifiability(g, combined, order, n_simulations=a.sims))
    cpu_ei = CPU_TIMES[-1]
    t_ref, sizes = timed(lambda: ref.expected_identifiability(g, combined, order, n_simulations=a.ref_sims))
    check = design.expected_identifiability(g, combined, order, n_simulations=a.ref_sims)
    assert np.array_equal(sizes, check.sizes), "edmf_rs and the reference disagree"
    print(f"  edmf_rs: {t_ei:.3f} s wall, {cpu_ei:.3f} s CPU (mean candidate set {r.mean:.1f}); NumPy reference: "
          f"{t_ref / a.ref_sims * 1e3:.1f} ms per simulation -> {t_ref / a.ref_sims * a.sims / t_ei:.0f}x")
    t_curve, c = timed(lambda: design.identifiability_curve(g, combined, order, n_simulations=a.sims))
    cpu_curve = CPU_TIMES[-1]
    print(f"  curve k = 1..{a.k}: {t_curve:.3f} s wall, {cpu_curve:.3f} s CPU; mean candidate-set sizes "
          + " ".join(f"{v:.0f}" for v in c.mean) + f"; smallest with {c.best} sensors")
    load = os.getloadavg()[0]
    print(f"\nTargets (N={a.n}, L={a.locations}, k={a.k}; {cpu_model()}, {edmf_rs.get_num_threads()} threads, "
          f"load average {load:.2f}; on a busy machine wall time exceeds CPU time / threads)")
    rows = [("greedy placement (lazy)", "<= 1.5 s", t_rust, cpu_rust, t_rust <= 1.5),
            ("  per pair vs NumPy (plain)", ">= 30x", None, None, pp_ref / pp_rust >= 30),
            (f"identifiability, {a.sims} sims", "<= 2 s", t_ei, cpu_ei, t_ei <= 2.0),
            (f"curve k = 1..{a.k}", "<= 20 s", t_curve, cpu_curve, t_curve <= 20.0)]
    print(f"  {'':32s} {'target':>9s} {'wall s':>8s} {'CPU s':>8s}  met")
    for name, target, wall, cpu, ok in rows:
        if wall is None:
            print(f"  {name:32s} {target:>9s} {pp_ref / pp_rust:>7.0f}x {'':>8s}  {'yes' if ok else 'NO'}")
        else:
            print(f"  {name:32s} {target:>9s} {wall:8.3f} {cpu:8.3f}  {'yes' if ok else 'NO'}")

    if a.big:
        n, n_loc = a.big
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "g.npy"
            mm = np.lib.format.open_memmap(path, mode="w+", dtype=np.float32, shape=(n, n_loc))
            for s in range(0, n, 100_000):
                mm[s:s + 100_000] = predictions(min(100_000, n - s), n_loc, seed=s)
            mm.flush()
            del mm
            g = np.load(path, mmap_mode="r")
            rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
            t_big, d = timed(lambda: design.place_sensors(g, np.full(n_loc, 0.05), a.k))
            rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
            print(f"\nMemory map {n} x {n_loc} float32 ({path.stat().st_size / 2**30:.1f} GiB): placement k={a.k} "
                  f"in {t_big:.1f} s, {d.evaluations} pairs; peak RSS {rss1 / 2**20:.2f} GiB "
                  f"(before: {rss0 / 2**20:.2f} GiB; file pages counted when resident)")


if __name__ == "__main__":
    main()
