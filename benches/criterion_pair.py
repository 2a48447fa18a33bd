"""Two (or more) `cargo bench` binaries of the Rust kernels side by side:
each round runs every binary once over the benchmarks matching FILTER, in
turn, so a slow spell of a shared host falls on all of them alike; per
benchmark the line gives each binary's median over the rounds of criterion's
middle throughput estimate (M rows/s) and every round's value.

    python benches/criterion_pair.py 'short_rows_(5|10)/typical/diagnose_bits/f32/Avx' 3 \
        old=/tmp/old/release/deps/kernels-HASH new=target/release/deps/kernels-HASH

Build an older commit's binary with `git worktree add /tmp/oldwt SHA` and
`CARGO_TARGET_DIR=/tmp/old cargo bench --bench kernels --no-run` there.
"""

from __future__ import annotations

import argparse
import collections
import re
import statistics
import subprocess

UNIT = {"Kelem/s": 1e-3, "Melem/s": 1.0, "Gelem/s": 1e3}


def rates(binary: str, pattern: str) -> dict[str, float]:
    """Criterion's middle throughput estimate (M rows/s) per benchmark of one run."""
    out = subprocess.run([binary, "--bench", pattern, "--warm-up-time", "1", "--measurement-time", "2", "--noplot"],
                         capture_output=True, text=True, check=True).stdout
    found, name = {}, None
    for line in out.splitlines():
        if line and not line[0].isspace() and "/" in line:
            name = line.split()[0]
        m = re.search(r"thrpt:\s+\[\S+ \S+ (\S+) (\S+)", line)
        if m and name and m.group(2) in UNIT:
            found[name] = float(m.group(1)) * UNIT[m.group(2)]
            name = None
    return found


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("filter", help="criterion's benchmark filter (a regular expression)")
    ap.add_argument("rounds", type=int, help="rounds; each runs every binary once")
    ap.add_argument("binaries", nargs="+", help="LABEL=PATH of each cargo bench binary")
    args = ap.parse_args()
    builds = [b.split("=", 1) for b in args.binaries]
    if any(len(b) != 2 for b in builds):
        ap.error("binaries: expected LABEL=PATH")
    runs = collections.defaultdict(list)
    for _ in range(args.rounds):
        for label, path in builds:
            for name, rate in rates(path, args.filter).items():
                runs[(name, label)].append(rate)
    labels = [label for label, _ in builds]
    print("bench".ljust(50), *(label.rjust(10) for label in labels), "  every round")
    for name in sorted({n for n, _ in runs}):
        cells = [runs.get((name, label), []) for label in labels]
        print(name.ljust(50), *(f"{statistics.median(c):.0f}".rjust(10) if c else "-".rjust(10) for c in cells),
              "  " + " ".join("/".join(f"{r:.0f}" for r in c) for c in cells))


if __name__ == "__main__":
    main()
