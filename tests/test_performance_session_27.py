"""Session 27's figures in docs/performance.md and README.md, recomputed from
the runs recorded in benches/results-short-rows.txt: the kernels alone
(`cargo bench --bench core_kernels`, the session start's build against this
session's), the two builds side by side through memory, and the floor tables."""

import re
import statistics
from collections import defaultdict
from pathlib import Path

from test_performance_tables import _floor_summary, _level_tables, _target

ROOT = Path(__file__).resolve().parents[1]
SHORT_ROWS = (ROOT / "benches" / "results-short-rows.txt").read_text()
PAGE_TEXT = (ROOT / "docs" / "performance.md").read_text()
PAGE = " ".join(PAGE_TEXT.split())
README = " ".join((ROOT / "README.md").read_text().split())


def _section(title: str) -> str:
    """The one section of the results file whose title starts with `title`."""
    found = [s for s in SHORT_ROWS.split("\n=== ") if s.startswith(title)]
    assert len(found) == 1, title
    return found[0]


def _alone(pair: str) -> dict:
    """Median GB/s with diagnostics per (version, level, dtype, n_m, case) over
    the runs of the section "session 27: the kernels alone, <pair> pair"."""
    section = _section(f"session 27: the kernels alone, {pair} pair")
    rates, version = defaultdict(list), None
    for line in section.splitlines():
        if line.startswith("--- "):
            version = line.split()[1]
        cells = line.split()
        if len(cells) == 6 and cells[0] in ("Avx512", "Avx2"):
            rates[(version, *cells[:4])].append(float(cells[4]))
    assert {len(v) for v in rates.values()} == {3}
    return {k: statistics.median(v) for k, v in rates.items()}


def _gains(level: str, dtype: str, widths: tuple[str, ...], case: str = "typical") -> list[float]:
    """new / old of the medians, both pairs, for rows of `widths` sensors."""
    return [m[("new", level, dtype, n, case)] / m[("old", level, dtype, n, case)]
            for m in (_alone("first"), _alone("second")) for n in widths]


def _span(values: list[float]) -> str:
    return f"{min(values):.2f}-{max(values):.2f}"


def test_the_kernel_alone_figures_match_the_recorded_runs():
    assert len(_alone("first")) == len(_alone("second")) == 2 * 2 * 8 * 2
    sentence = (f"typical float32 rows with diagnostics ran {_span(_gains('Avx512', 'f32', ('5', '10')))} times as "
                f"fast for rows of 5 and 10 sensors and {_span(_gains('Avx512', 'f32', ('20',)))} for rows of 20 at "
                f"AVX-512, and {_span(_gains('Avx2', 'f32', ('5', '10')))} and "
                f"{_span(_gains('Avx2', 'f32', ('20',)))} at AVX2")
    assert sentence in PAGE
    assert (f"float64 rows of 5 and 10, typical, with diagnostics {_span(_gains('Avx512', 'f64', ('5', '10')))} at "
            "AVX-512") in PAGE
    slower = _gains("Avx2", "f32", ("16",), "worst")
    assert f"AVX2 float32 rows of 16 in the worst case with diagnostics ran at {_span(slower)} of the old speed" in PAGE
    assert max(slower) < 1


def test_the_masked_subtract_figure_matches_the_recorded_runs():
    section = _section("session 27: the byte count as one masked subtract")
    rates = defaultdict(list)
    for line in section.splitlines()[1:]:
        version, *cells = line.split()
        for i in range(0, len(cells), 5):
            rates[(version, cells[i], cells[i + 1])].append(float(cells[i + 3]))
    assert {len(v) for v in rates.values()} == {4}
    gains = [statistics.median(rates[("fin", "f32", n)]) / statistics.median(rates[("intr", "f32", n)])
             for n in ("5", "10")]
    doc = " ".join((ROOT / "rust" / "src" / "simd" / "bit_string.rs").read_text().replace("///", "").split())
    assert f"typical f32 rows of 5 and 10 ran {_span(gains)} times as fast with this one" in doc


def _u128() -> dict:
    """Median GB/s with diagnostics per (version, level, dtype, n_m, case) of
    the section "session 27: u128 strings" (versions old, 8a697ea, new)."""
    rates, version = defaultdict(list), None
    for line in _section("session 27: u128 strings").splitlines():
        if line.startswith("--- "):
            version = line.split()[1].rstrip(",")
        cells = line.split()
        if len(cells) == 6 and cells[0] in ("Avx512", "Avx2"):
            rates[(version, *cells[:4])].append(float(cells[4]))
    assert {len(v) for v in rates.values()} == {3} and {k[0] for k in rates} == {"old", "8a697ea", "new"}
    return {k: statistics.median(v) for k, v in rates.items()}


def test_the_u128_figures_match_the_recorded_runs():
    m = _u128()
    back = m[("new", "Avx2", "f32", "16", "worst")] / m[("old", "Avx2", "f32", "16", "worst")]
    gained = [m[("new", "Avx512", "f32", n, "typical")] / m[("8a697ea", "Avx512", "f32", n, "typical")]
              for n in ("7", "14")]
    assert (f"that case then ran {back:.2f} times the old speed, and AVX-512 typical float32 rows of 7 and 14 with "
            f"diagnostics {_span(gained)} times that of the first commit") in PAGE
    assert back >= 0.97 and min(gained) > 1


def _paired(title: str) -> tuple[re.Match, dict]:
    """The median line and old/new per (n_m, dtype, case, mode) of a paired-builds section."""
    section = _section(title)
    median = re.search(r"old/new paired, median over (\d+) cases: ([\d.]+) \(range ([\d.]+)-([\d.]+)\)", section)
    cases = {m.group(1, 2, 3, 4): float(m[5]) for m in
             re.finditer(r"^\s*(\d+) (f\d\d)\s+(\w+)\s+(\w+)\s+floor.*old/new paired ([\d.]+)$", section, re.M)}
    assert median and len(cases) == int(median[1]) == 40
    return median, cases


def test_the_side_by_side_figures_match_the_recorded_runs():
    for level, title in (("AVX-512", "session 27: side by side"), ("AVX2", "session 27 AVX2: side by side")):
        median, cases = _paired(title)
        short = [cases[(n, "f32", "typical", "diag")] for n in ("5", "10")]
        assert (f"at {level}, {median[2]} by the median over the 40 cases ({median[3]}-{median[4]}) and "
                f"{_span(short)} for float32 rows of 5 and 10, typical, with diagnostics") in PAGE


def test_the_session_27_floor_table_matches_the_recorded_runs():
    summary = _floor_summary(SHORT_ROWS, PAGE_TEXT, "27")
    assert summary + "." in PAGE
    *_, medians = _level_tables(SHORT_ROWS, PAGE_TEXT, "27")
    missed = sorted(k for k, m in medians.items() if m < _target(k[1], k[3], k[4]))
    names = "; ".join(f"{'AVX-512' if k[0] == 'avx512' else 'AVX2'} {k[2]} rows of {k[1]}, {k[3]}, {k[4]} "
                      f"({medians[k]:.2f})" for k in missed)
    assert f"The misses: {names}." in PAGE
    ten = ("10", "f32", "typical", "diagnostics")
    assert (f"Session 25's misses of float32 rows of 10 (typical, diagnostics) now read {medians[('avx512', *ten)]:.2f} "
            f"of the floor at AVX-512 and {medians[('avx2', *ten)]:.2f} at AVX2") in PAGE
    assert all(k[1] in ("50", "200") for k in missed)
    *_, before = _level_tables(SHORT_ROWS, PAGE_TEXT, "25")
    assert f"session 25 measured the same seven cases at {_span([before[k] for k in missed])} by the median" in PAGE
    assert len(missed) == 7 and "All seven misses are rows of 50 and 200 sensors" in PAGE
    readme = summary.replace("By the median, AVX-512 reads", "AVX-512 read").split(". The floor")[0]
    assert f"Session 27 made the periodic kernel's diagnostics cheaper; {readme}" in README
    short = [_target(k[1], k[3], k[4]) - medians[k] for k in missed]
    assert (f"Float32 rows of 10 (typical, diagnostics) read {medians[('avx512', *ten)]:.2f} at AVX-512 and "
            f"{medians[('avx2', *ten)]:.2f} at AVX2; the seven misses are rows of 50 and 200 sensors, whose kernels "
            f"did not change, by {min(short):.2f}-{max(short):.2f}") in README
