"""Session 36's figures, recomputed from the runs recorded in
benches/results-long-rows.txt (sections "session 36: f32 rows of 65-128" and
"session 36: the AVX2 long-row kernel's diagnostics, three more tries") and
the floor table's runs in benches/results-short-rows.txt ("session 36 final
code", "session 36 AVX2 final code", with rows of 65 and 100): the Reading
lines there, the medium kernels' doc comments, the performance page and the
README."""

import re
import statistics

from test_performance_session_29 import PAGE, README, ROOT, _section, _span
from test_performance_session_34 import ISSUE_WIDTHS, check_floor_table, check_lowest_is_avx2_rows_of_9

WIDE = _section("session 36: f32 rows of 65-128")
TRIES = _section("session 36: the AVX2 long-row kernel's diagnostics, three more tries")
MEDIUM_DOCS = " ".join(
    (ROOT / "rust" / "src" / "simd" / name).read_text().replace("//!", "").replace("///", "")
    for name in ("medium.rs", "medium_avx2.rs")
).split()
MEDIUM_DOCS = " ".join(MEDIUM_DOCS)
# One case of paired_builds.py: width, case, old/floor, new/floor, paired time(old) / time(new).
PAIRED = re.compile(
    r"^ +(\d+) f32 +(\w+) diag .*\| old/floor ([\d.]+) .*\| new/floor ([\d.]+) .*old/new paired ([\d.]+)$", re.M
)
MEDIAN = re.compile(r"^old/new paired, median over (\d+) cases: ([\d.]+) \(range ([\d.]+)-([\d.]+)\)$", re.M)
# One case of core_kernels_pair.py with two builds.
ALONE = re.compile(r"^(Avx2|Avx512) (f32|f64) +(\d+) (\w+) \|.*\| new ([\d.]+)/([\d.]+)$", re.M)
# The kernels alone before the change: level, dtype, width, GB/s with diagnostics.
BEFORE = re.compile(r"^(Avx2|Avx512) (f32|f64) +(\d+) typical +([\d.]+) +[\d.]+$", re.M)


def _reading(section: str) -> str:
    (line,) = [line for line in section.splitlines() if line.startswith("Reading:")]
    return " ".join(line.split())


def _runs(level: str) -> list[str]:
    """The two paired_builds runs at `level` ("AVX-512" or "AVX2")."""
    parts = WIDE.split("\n--- ")
    return [p for p in parts if p.startswith(f"{level} through falsify")]


def _cases(level: str):
    return [(int(m[1]), m[2], float(m[3]), float(m[4]), float(m[5])) for run in _runs(level) for m in PAIRED.finditer(run)]


def test_each_run_prints_its_own_median():
    for level, n in (("AVX-512", 14), ("AVX2", 12)):
        runs = _runs(level)
        assert len(runs) == 2
        for run in runs:
            cases = [float(m[5]) for m in PAIRED.finditer(run)]
            (m,) = MEDIAN.findall(run)
            assert int(m[0]) == len(cases) == n
            assert abs(statistics.median(cases) - float(m[1])) <= 0.0015
            assert f"{min(cases):.3f}" == m[2] and f"{max(cases):.3f}" == m[3]


def _through_falsify() -> dict[str, str]:
    """The spans the Reading line, the page and the README quote."""
    spans = {}
    for level in ("AVX-512", "AVX2"):
        cases = _cases(level)
        wide_typical = [c for c in cases if c[0] >= 65 and c[1] == "typical"]
        assert len(wide_typical) == 8  # four widths, two runs
        spans[f"{level} paired"] = f"{min(c[4] for c in wide_typical):.3f}-{max(c[4] for c in wide_typical):.3f}"
        spans[f"{level} new"] = _span(c[3] for c in wide_typical)
        spans[f"{level} old"] = _span(c[2] for c in wide_typical)
    both = _cases("AVX-512") + _cases("AVX2")
    wide_worst = [c[4] for c in both if c[0] >= 65 and c[1] == "worst"]
    narrow = [c[4] for c in both if c[0] <= 64]
    assert len(wide_worst) == 16 and len(narrow) == 20
    spans["worst"] = f"{min(wide_worst):.3f}-{max(wide_worst):.3f}"
    spans["narrow"] = f"{min(narrow):.3f}-{max(narrow):.3f}"
    return spans


def test_through_falsify():
    s = _through_falsify()
    words = _reading(WIDE)
    assert (f"time(old) / time(new) on typical rows of 65-128 was {s['AVX-512 paired']} at AVX-512 and "
            f"{s['AVX2 paired']} at AVX2 (two runs each); worst rows of 65-128 {s['worst']} and rows of 33-64 "
            f"(whose code changed only in how the row's string is held) {s['narrow']}") in words
    assert (f"read {s['AVX-512 new']} of the floor at AVX-512 (old {s['AVX-512 old']} in the same runs) and "
            f"{s['AVX2 new']} at AVX2 (old {s['AVX2 old']})") in words
    assert (f"{s['AVX-512 paired']} at AVX-512 and {s['AVX2 paired']} at AVX2; worst-case rows of 65-128 {s['worst']} "
            f"and rows of 33-64 (whose code changed only in how the row's string is held) {s['narrow']}") in PAGE
    assert (f"read {s['AVX-512 new']} of the floor at AVX-512 ({s['AVX-512 old']} before, in the same runs) and "
            f"{s['AVX2 new']} at AVX2 ({s['AVX2 old']})") in PAGE
    assert (f"was {s['AVX-512 paired']} at AVX-512 and {s['AVX2 paired']} at AVX2, and those rows read "
            f"{s['AVX-512 new']} of the floor at AVX-512 and {s['AVX2 new']} at AVX2") in README


def test_alone():
    cases = [(m[1], m[2], int(m[3]), m[4], float(m[5])) for m in ALONE.finditer(WIDE)]
    def span(pick):
        values = [c[4] for c in cases if pick(*c[:4])]
        assert values
        return _span(values)
    wide512 = span(lambda lv, d, n, case: lv == "Avx512" and d == "f32" and n in (65, 128) and case != "worst")
    worst512 = span(lambda lv, d, n, case: lv == "Avx512" and d == "f32" and n in (65, 128) and case == "worst")
    wide2 = span(lambda lv, d, n, case: lv == "Avx2" and d == "f32" and 65 <= n <= 128 and case != "worst")
    worst2 = span(lambda lv, d, n, case: lv == "Avx2" and d == "f32" and 65 <= n <= 128 and case == "worst")
    narrow = span(lambda lv, d, n, case: n <= 64)
    past = span(lambda lv, d, n, case: n == 129)
    words = _reading(WIDE)
    assert (f"rows of 65 and 128 with diagnostics ran {wide512} times as fast at AVX-512 (worst {worst512}), and "
            f"rows of 65-128 {wide2} at AVX2 (worst {worst2}); rows of up to 64, whose code differs only in how "
            f"the row's string is declared, {narrow}, and AVX2 rows of 129 (the long-row kernel still) {past}") in words
    assert (f"rows of 65 and 128 with diagnostics ran {wide512} times as fast at AVX-512, and rows of 65-128 "
            f"{wide2} at AVX2") in PAGE


def test_before():
    rates = {(m[1], m[2], int(m[3])): m[4] for m in BEFORE.finditer(WIDE)}
    assert rates[("Avx512", "f32", 65)] == "15.1" and rates[("Avx512", "f32", 64)] == "46.8"
    assert rates[("Avx2", "f32", 65)] == "16.2" and rates[("Avx2", "f32", 64)] == "29.0"
    assert "typical rows of 65 read 15.1 GB/s at AVX-512 against 46.8 for rows of 64, and 16.2 against 29.0 at AVX2" in PAGE
    assert "typical rows of 65 read 15.1 GB/s against 46.8 for rows of 64" in README
    assert "typical rows of 65 with diagnostics read 16 GB/s alone on a core against 29 for rows of 64" in MEDIUM_DOCS
    before = WIDE.split("\n--- ")[1]
    assert before.startswith("before: python benches/throughput.py --floor")
    # Speed / floor, the third number after the method (the last is the
    # CPU-time ratio), one run.
    ratios = {int(l.split()[0]): l.split()[7] for l in before.splitlines() if l[:4].strip().isdigit()}
    assert ratios == {64: "0.95", 65: "0.63", 100: "0.87", 130: "0.72"}
    assert "at AVX-512 they read 0.63 of the floor (one run)" in PAGE
    assert "typical rows of 65 read 0.63 of the floor through `falsify`" in README
    assert "at 0.63 of the read floor through `falsify`" in MEDIUM_DOCS
    assert "(before, in one run: rows of 65 0.63, rows of 100 0.87)" in _reading(WIDE)


def test_the_tries():
    words = _reading(TRIES)
    rows = re.findall(r"^  (falsify diag|diag abl1) +speed / floor ([\d.]+) ", TRIES, re.M)
    whole = [float(v) for name, v in rows if name == "falsify diag"]
    abl1 = [float(v) for name, v in rows if name == "diag abl1"]
    assert len(whole) == len(abl1) == 6
    assert f"(abl1 {_span(abl1)} of the floor against {_span(whole)} for the whole kernel in the same runs)" in words
    assert f"typical rows of 200 read {_span(abl1)} of the floor against {_span(whole)} for the whole kernel" in PAGE
    planes = [float(m) for m in re.findall(r"planes ([\d.]+)/", TRIES)]
    four = [float(m) for m in re.findall(r"four ([\d.]+)/", TRIES)]
    assert f"ran {_span(planes)} times as fast alone" in words and f"ran {_span(planes)} times as fast alone" in PAGE
    assert max(four) < 0.85  # "as slowly"
    per_round = [float(m) for m in re.findall(r"per round ([\d.]+) \(", TRIES)]
    assert len(per_round) == 16
    assert f"Through memory, {_span(per_round)} by the per-round median" in words


def _after() -> dict[tuple[str, int], list[float]]:
    """Speed / floor of typical f32 rows with diagnostics after the change, per
    (level, width): one value a run."""
    (after,) = [p for p in WIDE.split("\n--- ") if p.startswith("after: ")]
    values: dict[tuple[str, int], list[float]] = {}
    level = None
    for line in after.splitlines():
        if line.startswith("== run "):
            level = line.split(", ")[1].split()[0]
            continue
        f = line.split()
        if len(f) == 11 and f[1] == "f32" and f[2] == "typical":
            values.setdefault((level, int(f[0])), []).append(float(f[7]))  # speed / floor
    return values


def test_after():
    values = _after()
    assert all(len(v) == 2 for v in values.values()) and len(values) == 8  # two runs
    def span(level, widths):
        return _span(v for w in widths for v in values[(level, w)])
    words = _reading(WIDE)
    assert (f"typical float32 rows of 65-128 with diagnostics read {span('AVX-512', (65, 100, 128))} of the floor at "
            f"AVX-512 (before, in one run: rows of 65 0.63, rows of 100 0.87) and {span('AVX2', (65, 100, 128))} at "
            f"AVX2, the lowest AVX2 rows of 65 "
            f"({span('AVX2', (65,))}: nine vectors") in words
    low = min(v for w in (65, 100, 128) for v in values[("AVX2", w)])
    assert low in values[("AVX2", 65)]
    assert (f"rows of 130, still the long-row kernels', {span('AVX-512', (130,))} at AVX-512 and "
            f"{span('AVX2', (130,))} at AVX2") in words


def test_the_session_36_floor_table():
    """Session 36's table (the README's until session 37), on the page: six
    runs at each level over ten widths, the issue's rule applied to rows of 65
    and 100 too, the floors, the misses, the lowest case."""
    texts = [(ROOT / "docs" / "performance.md").read_text()]
    a512, avx2, words = check_floor_table("36", texts, widths=(*ISSUE_WIDTHS, "65", "100"), n_widths=10)
    check_lowest_is_avx2_rows_of_9(a512, avx2, [words, PAGE])
