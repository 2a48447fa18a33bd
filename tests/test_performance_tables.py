"""The short-row table of docs/performance.md is the median and range of the
runs recorded in benches/results-short-rows.txt (sections "session 8 final
code"), and its side-by-side figures the span of the section "session 8: side
by side", recomputed here from that file: the page prints no number the
benchmark did not."""

import re
import statistics
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ROW = re.compile(r"\s*(\d+)\s+(f\d\d)\s+(\w+)\s+[\d,]+\s+(diagnostics|no diagnostics)\s+[\d.]+\s+[\d.]+\s+([\d.]+)")


def test_short_row_table_matches_the_recorded_runs():
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    runs = [s for s in text.split("\n=== ") if s.startswith("session 8 final code")]
    assert len(runs) == 6
    ratios = defaultdict(list)
    for run in runs:
        for m in map(ROW.match, run.splitlines()):
            if m:
                ratios[(m[1], m[2], m[3], m[4])].append(float(m[5]))
    page = (ROOT / "docs" / "performance.md").read_text()
    cases = sorted({k[:3] for k in ratios})
    assert len(cases) == 20
    for n_m, dtype, case in cases:
        cells = []
        for mode in ("diagnostics", "no diagnostics"):
            v = ratios[(n_m, dtype, case, mode)]
            assert len(v) == 6
            cells.append(f"{statistics.median(v):.2f} ({min(v):.2f}-{max(v):.2f})")
        assert f"| {n_m} | {dtype} | {case} | {cells[0]} | {cells[1]} |" in page


def test_side_by_side_figures_match_the_recorded_runs():
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    section = text.split("\n=== session 8: side by side")[1].split("\n=== ")[0]
    values = defaultdict(list)
    for line in section.splitlines():
        version, _, cells = line.partition(": ")
        if version in ("old", "main"):
            for cell in cells.split(" | "):
                *case, ratio = cell.split()
                values[(version, " ".join(case))].append(float(ratio))
    assert {len(v) for v in values.values()} == {3}
    page = " ".join((ROOT / "docs" / "performance.md").read_text().split())

    def span(version, case):
        v = values[(version, case)]
        return f"{min(v):.2f}-{max(v):.2f}"

    for case in ("5 float32 typical scr", "5 float32 worst diag", "5 float64 worst diag", "10 float64 worst diag",
                 "200 float32 worst diag", "200 float64 worst diag", "10 float32 typical diag"):
        assert f"from {span('old', case)} to {span('main', case)}" in page, case


def test_small_call_figures_match_the_recorded_runs():
    text = (ROOT / "benches" / "results-small-calls.txt").read_text()
    medians = defaultdict(list)
    for section in text.split("\n=== ")[1:]:
        version = section.split(",")[0]
        for m in re.finditer(r"^\s+(\d+)\s+(\d+)\s+\d+$", section, re.M):
            medians[(version, int(m[1]))].append(int(m[2]))
    assert {len(v) for v in medians.values()} == {3}
    page = " ".join((ROOT / "docs" / "performance.md").read_text().split())

    def span(version, rows):
        v = medians[(version, rows)]
        return f"{min(v)}-{max(v)} us"

    assert f"100 rows took {span('old', 100)} before and {span('main', 100)} after" in page
    assert f"1,000 rows {span('old', 1000)} and {span('main', 1000)}" in page
    assert f"6,000 rows {span('old', 6000)} and {span('main', 6000)}" in page
    assert f"{span('old', 7000)} and {span('main', 7000)}" in page
