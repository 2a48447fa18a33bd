"""Two (or more) `cargo bench` binaries of the Rust kernels side by side:
every benchmark matching FILTER is run by each binary in turn, then the next
benchmark, for ROUNDS rounds, so a slow spell of a shared host falls on all
binaries alike. Per benchmark the line gives each binary's median over the
rounds of criterion's middle throughput estimate (M rows/s), the median over
rounds of each binary's rate / the first binary's rate in the same round
("paired"), and every round's value.

    python benches/criterion_pair.py 'short_rows_(5|10)/typical/diagnose_bits/f32/Avx' 3 \\
        old=/tmp/old/release/deps/kernels-HASH new=target/release/deps/kernels-HASH

Build an older commit's binary with `git worktree add /tmp/oldwt SHA` and
`CARGO_TARGET_DIR=/tmp/old cargo bench --bench kernels --no-run` there.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess

UNIT = {"elem/s": 1e-6, "Kelem/s": 1e-3, "Melem/s": 1.0, "Gelem/s": 1e3}


def names(binary: str, pattern: str) -> list[str]:
    """The benchmarks of `binary` that match `pattern`, as criterion lists them."""
    out = subprocess.run([binary, "--list", pattern], capture_output=True, text=True, check=True).stdout
    return [line.rsplit(": ", 1)[0] for line in out.splitlines() if line.endswith(": benchmark")]


def rate(binary: str, name: str) -> float:
    """Criterion's middle throughput estimate (M rows/s) of one benchmark, run once."""
    exact = "^" + re.escape(name) + "$"
    # No saved baseline: the binaries share `target/criterion`, so criterion's
    # "change" lines would compare one binary's run with another's.
    out = subprocess.run([binary, "--bench", exact, "--warm-up-time", "1", "--measurement-time", "2", "--noplot",
                          "--discard-baseline"], capture_output=True, text=True, check=True).stdout
    m = re.search(r"thrpt:\s+\[\S+ \S+ (\S+) (\S+)", out)
    if not m or m.group(2) not in UNIT:
        raise SystemExit(f"{binary}: no throughput for {name}")
    return float(m.group(1)) * UNIT[m.group(2)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("filter", help="criterion's benchmark filter (a regular expression)")
    ap.add_argument("rounds", type=int, help="rounds; each runs every benchmark once with every binary")
    ap.add_argument("binaries", nargs="+", help="LABEL=PATH of each cargo bench binary")
    args = ap.parse_args()
    builds = [b.split("=", 1) for b in args.binaries]
    if any(len(b) != 2 for b in builds) or len({label for label, _ in builds}) < len(builds) or args.rounds < 1:
        ap.error("binaries: expected LABEL=PATH with distinct labels; rounds: at least 1")
    benchmarks = names(builds[0][1], args.filter)
    if not benchmarks:
        ap.error(f"no benchmark matches {args.filter!r}")
    labels = [label for label, _ in builds]
    print("bench".ljust(50), *(label.rjust(10) for label in labels),
          *(f"{label}/{labels[0]}".rjust(14) for label in labels[1:]), "  every round")
    for name in benchmarks:
        runs = [[rate(path, name) for _, path in builds] for _ in range(args.rounds)]
        cells = list(zip(*runs))
        paired = [statistics.median(r[i] / r[0] for r in runs) for i in range(1, len(builds))]
        print(name.ljust(50), *(f"{statistics.median(c):.0f}".rjust(10) for c in cells),
              *(f"{p:.3f}".rjust(14) for p in paired),
              "  " + " ".join("/".join(f"{r:.0f}" for r in c) for c in cells), flush=True)


if __name__ == "__main__":
    main()
