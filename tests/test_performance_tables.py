"""The short-row table of docs/performance.md is the median and range of the
runs recorded in benches/results-short-rows.txt (sections "session 9 final
code"), and its side-by-side figures the span of the section "session 8: side
by side", recomputed here from that file: the page prints no number the
benchmark did not."""

import re
import statistics
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ROW = re.compile(r"\s*(\d+)\s+(f\d\d)\s+(\w+)\s+[\d,]+\s+(diagnostics|no diagnostics)\s+[\d.]+\s+[\d.]+\s+([\d.]+)")


def _floor_ratios(text: str, session: str) -> tuple[int, dict]:
    """Runs of the section "session <session> final code" and, per (n_m, dtype,
    case, mode), the speed / floor of each run."""
    runs = [s for s in text.split("\n=== ") if s.startswith(f"session {session} final code")]
    ratios = defaultdict(list)
    for run in runs:
        for m in map(ROW.match, run.splitlines()):
            if m:
                ratios[(m[1], m[2], m[3], m[4])].append(float(m[5]))
    return len(runs), ratios


def test_short_row_table_matches_the_recorded_runs():
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    n_runs, ratios = _floor_ratios(text, "9")
    assert n_runs == 6
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


def test_session_9_kernel_figures_match_the_recorded_runs():
    """The kernel-alone spans quoted for session 9, and the largest move of a
    median between the session-8 and session-9 tables, from the recorded runs."""
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    section = text.split("\n=== session 9: cargo bench")[1].split("\n=== ")[0]
    rates = defaultdict(list)
    for line in section.splitlines():
        cells, arrow, version = line.partition(" <- ")
        if not arrow:
            continue
        for cell in filter(None, (c.strip() for c in cells.split("|"))):
            name, rate = cell.rsplit(" ", 1)
            rates[(version.strip(), name)].append(int(rate))
    page = " ".join((ROOT / "docs" / "performance.md").read_text().split())

    def moved(case):
        old, new = (rates[(v, f"short_rows_{case}/Avx512")] for v in ("old", "main"))
        assert len(old) == len(new) == 2
        return f"from {min(old)}-{max(old)} to {min(new)}-{max(new)}"

    assert f"every row a candidate went {moved('10/worst/diagnose_bits/f64')} M rows/s" in page
    assert f"most falsified, {moved('5/typical/diagnose_bits/f32')};" in page
    assert (f"most falsified, went {moved('10/typical/diagnose_bits/f64')} (f64) and "
            f"{moved('10/typical/diagnose_bits/f32')} (f32)") in page
    medians = {session: {k: statistics.median(v) for k, v in _floor_ratios(text, session)[1].items()}
               for session in ("8", "9")}
    assert len(medians["8"]) == len(medians["9"]) == 40
    largest = max(abs(medians["8"][k] - medians["9"][k]) for k in medians["9"])
    assert round(largest, 1) == 0.2
    assert "differ from these by up to 0.2 either way" in page
