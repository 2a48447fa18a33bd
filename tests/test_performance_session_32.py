"""Session 32's figures in docs/performance.md, the README and the AVX2 short-row
kernels' docs (rust/src/simd/medium_avx2_short.rs, medium_avx2_screen.rs),
recomputed from the side-by-side runs recorded in benches/results-short-rows.txt,
section "session 32: which rows the short-row kernels take"."""

import re

from test_performance_session_29 import PAGE, README, ROOT, SHORT_ROWS, _span
from test_performance_session_29 import _section as _section_of

SECTION = _section_of("session 32: which rows the short-row kernels take", SHORT_ROWS)
# One case of paired_builds.py: width, dtype, case, mode, the old build's paired
# speed / floor, the paired time(old) / time(new).
LINE = re.compile(r"^ +(\d+) (f32|f64) +(\w+) +(diag|scr) .*old/floor [\d.]+ \(paired ([\d.]+)\).*"
                  r"old/new paired ([\d.]+)$", re.M)


def _doc(name: str) -> str:
    text = (ROOT / "rust" / "src" / "simd" / name).read_text()
    return " ".join(text.replace("//!", "").replace("///", "").replace("//", "").split())


def _runs(*headings: str) -> list[tuple[int, str, str, str, float, float]]:
    found = []
    for heading in headings:
        parts = SECTION.split("--- " + heading)
        assert len(parts) == 2, heading
        found += [(int(m[1]), m[2], m[3], m[4], float(m[5]), float(m[6]))
                  for m in LINE.finditer(parts[1].split("\n--- ")[0])]
    return found


def _new_kernels(n: int, dtype: str, mode: str) -> bool:
    """Whether the final code sends these rows to session 31's kernels."""
    if dtype == "f64":
        return n <= 12
    return n <= (16 if mode == "scr" else 32)


def claims() -> dict[str, str]:
    final = _runs("the final code, run 1", "the final code, run 2")
    assert len(final) == 2 * 6 * 2 * 2 * 2
    v1 = _runs("v1, run 1", "v1, run 2", "v1, run 3",
               "prefetch tries, round 1, 'P1'", "prefetch tries, round 2, 'P1'")
    p1 = _runs("prefetch tries, round 1, 'P1'", "prefetch tries, round 2, 'P1'")
    v2 = _runs("v2, run 1", "v2, run 2", "v2, run 3")
    p2 = _runs("prefetch tries, round 1, 'P2'", "prefetch tries, round 2, 'P2'")
    p4 = _runs("prefetch tries, round 1, 'P4'", "prefetch tries, round 2, 'P4'")
    ratio = lambda rows, keep: [r[5] for r in rows if keep(*r[:4])]  # noqa: E731
    f64_13_worst = ratio(v1, lambda n, d, c, m: (n, d, c, m) == (13, "f64", "worst", "diag"))
    f64_13_scr = ratio(v1, lambda n, d, c, m: (n, d, m) == (13, "f64", "scr"))
    assert len(f64_13_worst) == 5 and len(f64_13_scr) == 8
    return {
        "new": _span(ratio(final, lambda n, d, c, m: _new_kernels(n, d, m))),
        "same": _span(ratio(final, lambda n, d, c, m: not _new_kernels(n, d, m))),
        "f64_11_scr": _span(ratio(final, lambda n, d, c, m: (n, d, m) == (11, "f64", "scr"))),
        "f64_11_old": _span(r[4] for r in final if r[:2] == (11, "f64") and r[3] == "scr"),
        "f32_scr": _span(ratio(final, lambda n, d, c, m: d == "f32" and n <= 13 and m == "scr")),
        "f32_diag": _span(ratio(final, lambda n, d, c, m: d == "f32" and n in (17, 25) and m == "diag")),
        "f64_13_worst": _span(f64_13_worst),
        "f64_13_scr": _span(f64_13_scr),
        "v2_11": _span(ratio(v2, lambda n, d, c, m: (n, m) == (11, "scr"))),
        "p1_11": _span(ratio(p1, lambda n, d, c, m: (n, d, m) == (11, "f64", "scr"))),
        "p1_11_diag": _span(ratio(p1, lambda n, d, c, m: (n, d, m) == (11, "f64", "diag"))),
        "p2_11_diag": _span(ratio(p2, lambda n, d, c, m: (n, d, m) == (11, "f64", "diag"))),
        "p2_11_scr": _span(ratio(p2, lambda n, d, c, m: (n, d, m) == (11, "f64", "scr"))),
        "p4_13_scr": _span(ratio(p4, lambda n, d, c, m: (n, d, m) == (13, "f64", "scr"))),
        "p4_13_diag": _span(ratio(p4, lambda n, d, c, m: (n, d, m) == (13, "f64", "diag"))),
    }


def test_the_final_code_side_by_side():
    c = claims()
    assert (f"time(old) / time(new) was {c['new']} on the rows the new kernels take (float64 rows of 11 "
            f"screened {c['f64_11_scr']}, float32 rows of 9-13 screened {c['f32_scr']}, float32 rows of 17 and 25 "
            f"with diagnostics {c['f32_diag']}), and {c['same']} on the rows that keep the loops of aea3b73") in PAGE
    assert (f"time(old) / time(new) {c['new']} on the rows they take and {c['same']} on the rows that went back "
            f"(the same code as before)") in README


def test_why_the_kernels_take_fewer_rows():
    c = claims()
    assert f"float64 rows of 13 read {c['f64_13_scr']} in all eight cases" in PAGE
    assert f"float64 rows of 13 read {c['f64_13_worst']} in the worst case in all five runs" in PAGE
    assert f"read {c['v2_11']} for float64 rows of 11 screened, where the new kernel read {c['p1_11']}" in PAGE
    assert f"the old loop screened those rows at {c['f64_11_old']} of the floor" in PAGE
    assert (f"float64 rows of 11 read {c['p2_11_diag']} with diagnostics and {c['p2_11_scr']} screened, against "
            f"{c['p1_11_diag']} and {c['p1_11']} without it), and none (float64 rows of 13 screened "
            f"{c['p4_13_scr']} but with diagnostics {c['p4_13_diag']})") in PAGE
    short, screen = _doc("medium_avx2_short.rs"), _doc("medium_avx2_screen.rs")
    assert f"rows of 13 {c['f64_13_worst']} in the worst case, in all five runs" in short
    assert f"float64 rows of 11 ran {c['f64_11_scr']} times as fast and float32 rows of 9-13 {c['f32_scr']}" in screen
    assert f"but float64 rows of 13 {c['f64_13_scr']}" in screen


def test_the_larger_buffer_not_kept():
    rows = _runs("tried and not kept, run 1", "tried and not kept, run 2")
    assert len(rows) == 2 * 5 * 2 * 2
    worst = _span(r[5] for r in rows if r[2] == "worst" and r[0] < 50)
    typical = _span(r[5] for r in rows if r[2] == "typical" and r[0] < 50)
    assert (f"2,048 rows at a time rather than 256 read {worst} in the worst case and {typical} in the typical "
            f"one on rows of 9-25 sensors with diagnostics") in PAGE


def test_session_31_figures_the_docs_repeat():
    s31 = _section_of("session 31: the AVX2 rows of 9-32 sensors", SHORT_ROWS)
    side = [m for run in s31.split("--- through falsify, side by side")[1:]
            for m in LINE.finditer(run.split("\nReading")[0])]
    f64_17 = _span(float(m[6]) for m in side if (m[1], m[2], m[4]) == ("17", "f64", "diag"))
    longer = _span(float(m[6]) for m in side if int(m[1]) >= 17 and m[4] == "scr")
    assert f"float64 rows of 17 ran {f64_17} times as fast with diagnostics" in _doc("medium_avx2_short.rs")
    assert f"rows of 17-64 {longer}" in _doc("medium_avx2_screen.rs")
    assert f"(with the new kernel they read {longer} in session 31)" in PAGE


ALONE = re.compile(r"^Avx2 (f32|f64) +(\d+) (\w+) \|[^\n]*\| new ([\d.]+)/([\d.]+)$", re.M)


def _alone(heading: str) -> list[tuple[str, int, str, float]]:
    part = SECTION.split("--- " + heading)[1].split("\n--- ")[0]
    return [(m[1], int(m[2]), m[3], float(m[4])) for m in ALONE.finditer(part)]


def test_the_counters_by_one_or():
    alone = _alone("kept: the short-row kernel's counters by one OR") + _alone("kept: the counters by one OR, alone")
    assert len(alone) == 7 * 3 + 5 * 3
    others = _span(r for _, _, case, r in alone if case != "worst")
    worst = _span(r for _, _, case, r in alone if case == "worst")
    side = _runs("kept: the counters by one OR, side by side through falsify, run 1",
                 "kept: the counters by one OR, side by side through falsify, run 2")
    assert len(side) == 2 * 5 * 2 * 2
    takes = lambda n, d: d == "f32" or n <= 12  # noqa: E731  (the short-row kernel's rows)
    typical = _span(r[5] for r in side if takes(r[0], r[1]) and r[2] == "typical")
    worst_side = _span(r[5] for r in side if takes(r[0], r[1]) and r[2] == "worst")
    controls = _span(r[5] for r in side if not takes(r[0], r[1]))
    assert (f"rows with diagnostics that are not all candidates ran {others} times as fast and the worst case "
            f"{worst}") in " ".join(PAGE.split())
    assert (f"the rows this kernel takes read {typical} in the typical case and {worst_side} in the worst, "
            f"float64 rows of 13-25 (controls) {controls}") in " ".join(PAGE.split())
    assert f"its rows read {typical} times as fast in the typical case and {worst_side} in the worst" in \
        " ".join(README.split())
    assert f"the rows not all candidates ran {others} times as fast" in _doc("medium_avx2_short.rs")


def test_the_scalar_counters_not_kept():
    alone = _alone('tried and not kept: the short-row kernel\'s "falsified only by" in scalar counters')
    assert len(alone) == 7 * 3
    others = _span(r for _, _, case, r in alone if case != "worst")
    assert f"rows that are not all candidates ran {others} times as fast (same section" in " ".join(PAGE.split())
