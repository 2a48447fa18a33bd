"""Adaptive EDMF against dense Sobol' sampling (issue 16 targets).

For the girder (3 parameters) and a 5-parameter variant (plus the right
support's rotational stiffness and a truck-load factor), finds the smallest
dense Sobol' run whose candidate ranges (per parameter, in % of the domain)
and prognosis interval (midspan deflection under a lane load, in % of its
width) are within 2 % of the best known ones, and compares the real model
runs it needs with those of ``edmf_rs.adaptive_falsify``. Every candidate of
either method passes Eq. 8 on a real model run, so the true ranges hold the
union of both methods' candidates: "best known" is that union (a dense run
of 2^17 instances and the adaptive run). Everything is measured in one run,
side by side.

    python benches/adaptive.py [--reference-log2 17] [--n-screen 65536] [--out benches/results-adaptive.txt]
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import time

import edmf_rs
import numpy as np
from edmf_rs import cli
from edmf_rs.engine.sampling import Parameter, sobol
from edmf_rs.examples import girder


def cpu_model() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        return next(line.split(":", 1)[1].strip() for line in out.splitlines() if line.startswith("Model name"))
    except Exception:
        return platform.processor() or "unknown"


def setup():
    project = edmf_rs.Project.from_toml(cli.EXAMPLES / "girder-sg5-excluded.toml")
    thresholds = edmf_rs.threshold_bounds(project.combined_uncertainty(), project.phi, project.correction)
    kept = list(project.kept)

    def model3(theta):
        return girder.predict(theta)[:, kept]

    def model5(theta):
        d = girder.displacements(theta[:, :3], girder._TRUCK, k_right=theta[:, 3])
        return (d @ girder._H.T)[:, kept] * theta[:, 4:5]

    def qoi3(theta):
        return girder.midspan_deflection(theta)

    def qoi5(theta):
        d = girder.displacements(theta[:, :3], girder._lane_load(40.0), k_right=theta[:, 3])
        return -d[:, 3 * girder._node(girder.SPAN / 2) + 1]

    p3 = project.parameters
    p5 = p3 + (Parameter("K_right", 1e9, 1e12, scale="log"), Parameter("load", 0.95, 1.05))
    return project.measured, thresholds, [("girder, 3 parameters", model3, qoi3, p3),
                                          ("girder, 5 parameters", model5, qoi5, p5)]


def unit_ranges(theta, params):
    u = np.column_stack([p.to_unit(theta[:, j]) for j, p in enumerate(params)])
    return np.stack([u.min(axis=0), u.max(axis=0)])


def compare(theta, qoi, params, ref_ranges, ref_q):
    """(largest range deviation in % of the domain, prognosis deviation in % of the reference width)."""
    if theta.shape[0] == 0:
        return np.inf, np.inf
    q = qoi(theta)
    dr = 100 * np.abs(unit_ranges(theta, params) - ref_ranges).max()
    dq = 100 * max(abs(q.min() - ref_q[0]), abs(q.max() - ref_q[1])) / (ref_q[1] - ref_q[0])
    return dr, dq


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--reference-log2", type=int, default=17)
    ap.add_argument("--n-screen", type=int, default=2**16)
    ap.add_argument("--out", default="benches/results-adaptive.txt")
    args = ap.parse_args()
    y, thresholds, cases = setup()
    lines = [f"benches/adaptive.py on {cpu_model()}, {edmf_rs.get_num_threads()} threads, "
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average at the start "
             f"{os.getloadavg()[0]:.1f} (CPU times below are per process; run counts do not depend on load)",
             f"reference: dense Sobol' 2^{args.reference_log2}; target: ranges within 2 % of the domain and the "
             "prognosis interval within 2 % of its width"]
    for name, model, qoi, params in cases:
        t0 = time.process_time()
        theta = sobol(params, 2**args.reference_log2, seed=42).all()
        ref = edmf_rs.falsify_model(model, theta, y, thresholds, progress=False)
        ref_cpu = time.process_time() - t0
        budget = 40 * len(params) + 300
        t0 = time.process_time()
        r = edmf_rs.adaptive_falsify(model, params, y, thresholds, budget=budget, n_screen=args.n_screen, seed=0)
        cpu = time.process_time() - t0
        union = np.vstack([ref.candidate_parameters, r.candidate_parameters])
        ref_ranges = unit_ranges(union, params)
        q = qoi(union)
        ref_q = (q.min(), q.max())
        lines.append(f"\n{name}: dense reference {theta.shape[0]:,} runs, {ref.n_candidates} candidates, "
                     f"{ref_cpu:.1f} s CPU; best known prognosis interval {ref_q[0]:.3f} .. {ref_q[1]:.3f} mm")
        dr, dq = compare(ref.candidate_parameters, qoi, params, ref_ranges, ref_q)
        reference_meets = dr <= 2 and dq <= 2
        first_line = len(lines) - 1
        lines.append(f"  dense 2^{args.reference_log2} = {theta.shape[0]:>7,} runs: {ref.n_candidates:>5} candidates, "
                     f"ranges off by {dr:6.2f} % of the domain, prognosis off by {dq:6.2f} % of its width")
        needed = None
        for k in range(8, args.reference_log2):
            part = edmf_rs.falsify(model(theta[:2**k]), y, thresholds, progress=False)
            dr, dq = compare(theta[:2**k][part.candidate_indices], qoi, params, ref_ranges, ref_q)
            lines.append(f"  dense 2^{k:<2} = {2**k:>7,} runs: {part.n_candidates:>5} candidates, ranges off by "
                         f"{dr:6.2f} % of the domain, prognosis off by {dq:6.2f} % of its width")
            if needed is None and dr <= 2 and dq <= 2:
                needed = 2**k
        if needed is None and reference_meets:
            needed = theta.shape[0]
        dr, dq = compare(r.candidate_parameters, qoi, params, ref_ranges, ref_q)
        ok = "meets" if dr <= 2 and dq <= 2 else "MISSES"
        lines.append(f"  adaptive: {r.n_runs} runs in {len(r.waves)} waves (budget {budget}, n_screen "
                     f"{args.n_screen:,}, stop: {r.stop_reason}), {r.n_candidates} candidates, ranges off by "
                     f"{dr:.2f} % of the domain, prognosis off by {dq:.2f} % ({ok} the 2 % target); "
                     f"{cpu:.1f} s CPU of emulation and screening with the model")
        for w in r.waves:
            lines.append(f"    wave {w.index} ({w.kind}): {w.n_runs} runs" + (
                "" if w.kept_fraction is None else
                f", kept {w.kept_fraction:.3g} of the domain, validated {w.validated}, "
                f"LOO error <= {np.max(w.loo_error):.3g} widths, sigma/width {w.sigma_ratio:.3g}"))
        if needed:
            lines.append(f"  dense Sobol' needs {needed:,} runs for the 2 % target: adaptive used "
                         f"{r.n_runs / needed:.2g} of that ({needed / r.n_runs:.1f} x fewer runs)")
        else:
            lines.append(f"  no dense run up to 2^{args.reference_log2} met the 2 % target; adaptive used "
                         f"{r.n_runs / theta.shape[0]:.4f} of 2^{args.reference_log2} runs")
        print("\n".join(lines[first_line:]), flush=True)
    finish(lines + [""], args.out)


def finish(lines: list[str], out: str) -> None:
    """The table with the load average at the end, printed and written to ``out``
    (also for benches/adaptive_basis.py)."""
    text = "\n".join(lines + [f"load average at the end {os.getloadavg()[0]:.1f}"]) + "\n"
    print(text)
    with open(out, "w") as fh:
        fh.write(text)


if __name__ == "__main__":
    main()
