"""Session 37's figures, recomputed from the runs recorded in
benches/results-long-rows.txt (section "session 37: the AVX2 medium kernel
takes f64 rows of 65-96 and f32 rows of 129-200") and the floor table's runs
in benches/results-short-rows.txt ("session 37 final code", "session 37 AVX2
final code", with rows of 150): the medium kernel's doc comments, the
performance page and the README."""

import re
import statistics

from test_performance_session_29 import PAGE, README, ROOT, SHORT_ROWS, _section
from test_performance_session_34 import ISSUE_WIDTHS, check_floor_table, check_lowest_is_avx2_rows_of_9
from test_performance_tables import _cases_table

SECTION = _section("session 37: the AVX2 medium kernel takes f64 rows of 65-96 and f32 rows of 129-200")
MEDIUM_DOC = " ".join((ROOT / "rust" / "src" / "simd" / "medium_avx2.rs").read_text()
                      .replace("//!", "").replace("///", "").split())
# One case of core_kernels_pair.py with two builds: dtype, width, case, paired diagnostics ratio.
ALONE = re.compile(r"^Avx2 (f32|f64) +(\d+) (\w+) \|.*\| new ([\d.]+)/[\d.]+$", re.M)
# One case of paired_builds.py: width, dtype, case, old/floor, new/floor, time(old) / time(new).
PAIRED = re.compile(
    r"^ +(\d+) (f32|f64) +(\w+) +(?:diag|scr) .*\| old/floor ([\d.]+) .*\| new/floor ([\d.]+) .*old/new paired ([\d.]+)$", re.M
)
MEDIAN = re.compile(r"^old/new paired, median over (\d+) cases: ([\d.]+) \(range ([\d.]+)-([\d.]+)\)$", re.M)


def _part(title: str) -> list[str]:
    """The parts of the section whose heading line starts with `title`."""
    return [p for p in SECTION.split("\n--- ") if p.startswith(title)]


def _alone(title: str) -> dict[tuple[str, int, str], float]:
    (part,) = _part(title)
    return {(m[1], int(m[2]), m[3]): float(m[4]) for m in ALONE.finditer(part)}


def _range(values, digits: int = 2) -> str:
    """Lowest-highest, or the one value where they are the same."""
    values = list(values)
    assert values
    low, high = f"{min(values):.{digits}f}", f"{max(values):.{digits}f}"
    return low if low == high else f"{low}-{high}"


def _pick(rates: dict, dtype: str, widths: range, cases: tuple[str, ...]) -> list[float]:
    picked = [r for (d, k, c), r in rates.items() if d == dtype and k in widths and c in cases]
    assert picked, (dtype, widths, cases)
    return picked


def alone_spans() -> dict[str, str]:
    """The kernels alone: the widths the medium kernel now takes, and the
    widths on either side whose kernel did not change."""
    rates = _alone("AVX2 kernels alone")
    assert len(rates) == 14 * 3
    return {
        "f64 typical": _range(_pick(rates, "f64", range(65, 97), ("typical", "singles"))),
        "f64 worst": _range(_pick(rates, "f64", range(65, 97), ("worst",))),
        "f32 typical": _range(_pick(rates, "f32", range(129, 201), ("typical", "singles"))),
        "f32 worst": _range(_pick(rates, "f32", range(129, 201), ("worst",))),
        "unchanged": _range([r for (d, k, c), r in rates.items()
                             if (d, k) in {("f64", 64), ("f64", 97), ("f64", 100), ("f32", 128), ("f32", 201)}]),
    }


def tried_span(cases: tuple[str, ...] = ("typical", "singles")) -> str:
    """The cap not kept: f64 rows of 112 and 128 on the medium kernel."""
    rates = _alone("tried: AVX2 f64 rows of up to 128")
    return _range(_pick(rates, "f64", range(101, 129), cases))


def _runs(title: str = "AVX2 through falsify") -> list[str]:
    runs = _part(title)
    assert len(runs) == 2
    return runs


def test_each_run_prints_its_own_median():
    for run in _runs() + _runs("AVX2 screening without a masked load"):
        cases = [float(m[6]) for m in PAIRED.finditer(run)]
        (m,) = MEDIAN.findall(run)
        assert int(m[0]) == len(cases) == 16
        assert abs(statistics.median(cases) - float(m[1])) <= 0.0015
        assert f"{min(cases):.3f}" == m[2] and f"{max(cases):.3f}" == m[3]


def through_falsify() -> dict[str, str]:
    cases = [(int(m[1]), m[2], m[3], float(m[4]), float(m[5]), float(m[6])) for run in _runs() for m in PAIRED.finditer(run)]
    new_widths = [c for c in cases if (c[1] == "f64" and 65 <= c[0] <= 96) or (c[1] == "f32" and 129 <= c[0] <= 200)]
    typical = [c for c in new_widths if c[2] == "typical"]
    worst = [c for c in new_widths if c[2] == "worst"]
    f32_150 = [c for c in typical if c[:2] == (150, "f32")]
    assert len(typical) == len(worst) == 8 and len(f32_150) == 2
    return {
        "typical": _range((c[5] for c in typical), 3),
        "worst": _range((c[5] for c in worst), 3),
        "typical new": _range(c[4] for c in typical),
        "typical old": _range(c[3] for c in typical),
        "150 old": _range(c[3] for c in f32_150),
        "150 new": _range(c[4] for c in f32_150),
        "200 worst": _range((c[5] for c in worst if c[:2] == (200, "f32")), 3),
        "200 worst floor": _range(v for c in worst if c[:2] == (200, "f32") for v in c[3:5]),
        "96 worst": sorted(f"{c[5]:.3f}" for c in worst if c[:2] == (96, "f64")),
        "65 worst": sorted((f"{c[5]:.3f}" for c in worst if c[:2] == (65, "f64")), key=lambda r: r >= "1"),
        "lost": sum(1 for c in worst if c[5] < 1),
    }


def screening() -> dict[str, str]:
    """Screening with the row's last vector a whole load: rows of 150 f32, the others."""
    cases = [(int(m[1]), m[2], float(m[4]), float(m[5]), float(m[6]))
             for run in _runs("AVX2 screening without a masked load") for m in PAIRED.finditer(run)]
    rows_150 = [c for c in cases if c[:2] == (150, "f32")]
    others = [c for c in cases if c[:2] != (150, "f32")]
    assert len(rows_150) == 4 and len(others) == 28
    return {
        "150": _range((c[4] for c in rows_150), 3),
        "150 old": _range(c[2] for c in rows_150),
        "150 new": _range(c[3] for c in rows_150),
        "others": _range((c[4] for c in others), 3),
    }


def test_screening_before_as_quoted():
    """The first AVX2 table runs (before the change): f32 rows of 150 without diagnostics."""
    runs = [r for r in SHORT_ROWS.split("\n=== ") if r.startswith("session 37 AVX2 before the screening change")]
    assert len(runs) == 6
    ratios = _cases_table(runs)
    before = ratios[("150", "f32", "worst", "no diagnostics")] + ratios[("150", "f32", "typical", "no diagnostics")]
    assert len(before) == 12
    claim = f"in this session's first AVX2 table runs float32 rows of 150 without diagnostics read {_range(before)} of the floor"
    assert claim in PAGE


def test_screening_as_quoted():
    s = screening()
    doc = " ".join((ROOT / "rust" / "src" / "simd" / "long_avx2.rs").read_text().replace("//", "").split())
    claim = (f"screening float32 rows of 150 then ran {s['150']} times as fast, from {s['150 old']} of the read "
             f"floor to {s['150 new']}, and rows of 129, 170 and 200 and float64 rows {s['others']}")
    assert claim in doc and claim in PAGE
    assert f"screening float32 rows of 150 ran {s['150']} times as fast" in README


def test_the_kernels_alone_as_quoted():
    s = alone_spans()
    claim = (f"typical and single-rejection float64 rows of 65-96 with diagnostics ran {s['f64 typical']} times as fast "
             f"(worst case {s['f64 worst']}) and float32 rows of 129-200 {s['f32 typical']} (worst case {s['f32 worst']})")
    assert claim in MEDIUM_DOC and claim in PAGE
    assert f"rows whose kernel did not change {s['unchanged']}" in PAGE
    claim = f"rows of 112 and 128 ran {tried_span()} times as fast (typical and single"
    assert claim in " ".join(MEDIUM_DOC.split()) and claim in PAGE
    assert f"rejections; worst case {tried_span(('worst',))})" in MEDIUM_DOC
    assert f"rejections; worst case {tried_span(('worst',))}): float64 stops at 96" in PAGE


def test_through_falsify_as_quoted():
    s = through_falsify()
    claim = (f"time(old) / time(new) on typical rows of these widths (float64 rows of 65 and 96, float32 rows of 150 "
             f"and 200) with diagnostics was {s['typical']} "
             f"and on worst-case rows {s['worst']}")
    assert claim in PAGE and claim in README
    assert f"typical rows read {s['typical new']} of the floor ({s['typical old']} before, in the same runs)" in PAGE
    claim = f"typical float32 rows of 150 with diagnostics read {s['150 old']} of the floor through `falsify`"
    assert claim in PAGE and claim in README and claim in MEDIUM_DOC
    assert f"and {s['150 new']} now" in PAGE
    assert (f"Worst-case float32 rows of 200 ran {s['200 worst']} times as fast in both runs "
            f"({s['200 worst floor']} of the floor either way); the other worst-case rows that lost were float64 rows "
            f"of 96 ({s['96 worst'][0]} and {s['96 worst'][1]}) and of 65 in one run ({s['65 worst'][0]}, and "
            f"{s['65 worst'][1]} in the other)") in PAGE
    assert s["lost"] == 5


def test_the_current_floor_table():
    """The README's table (and the page's session 37 section): six runs at each
    level over eleven widths, the issue's rule applied to rows of 65, 100 and
    150 too, the floors, the misses, the lowest case."""
    texts = [(ROOT / "docs" / "performance.md").read_text(), (ROOT / "README.md").read_text()]
    a512, avx2, words = check_floor_table("37", texts, widths=(*ISSUE_WIDTHS, "65", "100", "150"), n_widths=11)
    check_lowest_is_avx2_rows_of_9(a512, avx2, [words, PAGE])


def test_the_misses_read_higher_in_session_36():
    """The kernels of this table's misses did not change since session 36: their medians there, as quoted."""
    from test_performance_session_34 import _level

    (a512_36, _), (avx2_36, _) = _level("36"), _level("36 AVX2")
    med = lambda r, k: f"{statistics.median(r[k]):.2f}"  # noqa: E731
    at512 = [med(a512_36, ("200", d, "typical", m)) for d, m in
             (("f32", "diagnostics"), ("f32", "no diagnostics"), ("f64", "diagnostics"))]
    at2 = [med(avx2_36, ("16", d, "typical", "diagnostics")) for d in ("f32", "f64")]
    claim = (f"in session 36's table they read {at512[0]}, {at512[1]} and {at512[2]} at AVX-512 and "
             f"{at2[0]} and {at2[1]} at AVX2")
    assert claim in README and claim in PAGE


def test_the_two_avx2_batches_as_quoted():
    """The unchanged AVX2 short-row kernels' medians in the first and the final AVX2 runs."""
    first = _cases_table([r for r in SHORT_ROWS.split("\n=== ")
                          if r.startswith("session 37 AVX2 before the screening change")])
    final = _cases_table([r for r in SHORT_ROWS.split("\n=== ") if r.startswith("session 37 AVX2 final code")])
    med = lambda r, n: f"{statistics.median(r[(n, 'f32', 'typical', 'diagnostics')]):.2f}"  # noqa: E731
    assert (f"float32 rows of 9, typical with diagnostics, {med(first, '9')} and then {med(final, '9')}, "
            f"rows of 16 {med(first, '16')} and then {med(final, '16')}") in PAGE
