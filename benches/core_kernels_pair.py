"""Two (or more) `cargo bench --bench core_kernels` binaries side by side:
each runs the cases CASES (as `CORE_KERNELS` takes them) in turn, for ROUNDS
rounds, the order reversed every other round, so a slow spell of a shared
host falls on all binaries alike. Per case and level the line gives each
binary's median over the rounds of GB/s with diagnostics and screening, then
each later binary's median over rounds of its rate / the first binary's rate
in the same round ("paired", diagnostics/screening).

    python benches/core_kernels_pair.py f32:200,f64:65 5 \\
        old=/tmp/old/release/deps/core_kernels-HASH new=target/release/deps/core_kernels-HASH

Build an older commit's binary with `git worktree add /tmp/oldwt SHA` and
`CARGO_TARGET_DIR=/tmp/old cargo bench --bench core_kernels --no-run` there.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
from collections import defaultdict


def run(binary: str, cases: str) -> dict[tuple[str, ...], tuple[float, float]]:
    """GB/s (diagnostics, screening) per (level, dtype, n_m, case) of one run of `binary`."""
    out = subprocess.run([binary], env=dict(os.environ, CORE_KERNELS=cases),
                         capture_output=True, text=True, check=True).stdout
    rates = {}
    for line in out.splitlines():
        f = line.split()
        if len(f) == 6 and f[0] in ("Avx2", "Avx512"):
            rates[tuple(f[:4])] = (float(f[4]), float(f[5]))
    return rates


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", help="dtype:n_m pairs, as CORE_KERNELS takes them (f32:200,f64:65)")
    ap.add_argument("rounds", type=int)
    ap.add_argument("binaries", nargs="+", metavar="LABEL=BINARY")
    args = ap.parse_args(argv)
    labelled = [b.split("=", 1) for b in args.binaries]
    if any(len(lb) != 2 for lb in labelled) or len(labelled) < 2:
        ap.error("give two or more LABEL=BINARY")
    rounds = defaultdict(list)  # label -> one dict of rates a round
    for r in range(args.rounds):
        for label, binary in (labelled if r % 2 == 0 else labelled[::-1]):
            rounds[label].append(run(binary, args.cases))
    first = labelled[0][0]
    print("level dtype n_m case | " + " | ".join(f"{label}: diag scr (GB/s)" for label, _ in labelled)
          + " | paired diag/scr vs " + first)
    for key in rounds[first][0]:
        medians = [tuple(statistics.median(rd[key][i] for rd in rounds[label]) for i in (0, 1))
                   for label, _ in labelled]
        paired = []
        for label, _ in labelled[1:]:
            ratio = [statistics.median(b[key][i] / a[key][i] for a, b in zip(rounds[first], rounds[label]))
                     for i in (0, 1)]
            paired.append(f"{label} {ratio[0]:.2f}/{ratio[1]:.2f}")
        print(" ".join(key) + " | " + " | ".join(f"{d:5.1f} {s:5.1f}" for d, s in medians) + " | " + " ".join(paired),
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
