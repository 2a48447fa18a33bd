"""Session 33's figures in docs/performance.md, the README and `Period::new`'s
doc (rust/src/bounds.rs), recomputed from the runs recorded in
benches/results-short-rows.txt, section "session 33: patterns repeated in a period"."""

import re

from test_performance_session_29 import PAGE, README, ROOT, SHORT_ROWS, _span
from test_performance_session_29 import _section as _section_of

SECTION = _section_of("session 33: patterns repeated in a period", SHORT_ROWS)
# One case of paired_builds.py: width, dtype, case, mode, the new build's paired
# speed / floor, the paired time(old) / time(new).
LINE = re.compile(r"^ +(\d+) (f32|f64) +(\w+) +(diag|scr) .*new/floor [\d.]+ \(paired ([\d.]+)\).*"
                  r"old/new paired ([\d.]+)$", re.M)
# One case of core_kernels_pair.py: level, dtype, width, case, paired diag/scr.
ALONE = re.compile(r"^(Avx2|Avx512) (f32|f64) +(\d+) (\w+) \|[^\n]*\| new ([\d.]+)/([\d.]+)$", re.M)
BOUNDS = " ".join((ROOT / "rust" / "src" / "bounds.rs").read_text().replace("///", "").split())
# Widths whose pattern was one vector a period (two to eight rows).
ONE_VECTOR = {("f32", 2), ("f32", 4), ("f32", 8), ("f64", 2), ("f64", 4)}


def _part(heading: str) -> str:
    parts = SECTION.split("--- " + heading)
    assert len(parts) == 2, heading
    return parts[1].split("\n--- ")[0]


def _runs(*headings: str) -> list[tuple[int, str, str, str, float, float]]:
    return [(int(m[1]), m[2], m[3], m[4], float(m[5]), float(m[6]))
            for h in headings for m in LINE.finditer(_part(h))]


def _alone(heading: str) -> list[tuple[str, str, int, str, float, float]]:
    return [(m[1], m[2], int(m[3]), m[4], float(m[5]), float(m[6])) for m in ALONE.finditer(_part(heading))]


def claims() -> dict[str, str]:
    final = _runs("final through falsify, AVX-512", "final through falsify, AVX2")
    assert len(final) == 2 * 6 * 2 * 2 * 2
    typical_diag = lambda r: r[2:4] == ("typical", "diag")  # noqa: E731
    one = [r for r in final if typical_diag(r) and (r[1], r[0]) in ONE_VECTOR]
    six_twelve = [r for r in final if typical_diag(r) and r[1] == "f64" and r[0] in (6, 12)]
    rest = [r for r in final if r not in one and r not in six_twelve]
    alone = _alone("final ('C', AVX2 screening with the unrepeated period), the kernels alone (3 rounds)")
    alone_one = lambda level: [r[4] for r in alone  # noqa: E731
                               if r[0] == level and r[3] == "typical" and (r[1], r[2]) in ONE_VECTOR]
    alone_612 = [r[4] for r in alone if r[3] == "typical" and r[1] == "f64" and r[2] in (6, 12)]
    a_scr = [r[5] for r in _runs("'A' through falsify, run 1", "'A' through falsify, run 2")
             if (r[0], r[1], r[3]) == (4, "f64", "scr")]
    c_scr = [r[5] for r in _runs("'C' against the session start, AVX2", "'C' screened against the session start, AVX2")
             if r[0] == 4 and r[3] == "scr"]
    b_scr = [r[5] for r in _runs("'B' against 'A', run 2") if r[0] in (2, 4) and r[3] == "scr"]
    b_diag = [r[5] for r in _runs("'B' against 'A', run 2") if r[0] in (3, 12) and r[2:4] == ("typical", "diag")]
    return {
        "one": _span(r[5] for r in one),
        "one_floor": _span(r[4] for r in one),
        "six_twelve": _span(r[5] for r in six_twelve),
        "rest": _span(r[5] for r in rest),
        "alone512": _span(alone_one("Avx512")),
        "alone2": _span(alone_one("Avx2")),
        "alone612": _span(alone_612),
        "a_scr": _span(a_scr),
        "c_scr": _span(c_scr),
        "b_scr": _span(b_scr),
        "b_diag": _span(b_diag),
    }


def test_the_final_code_side_by_side():
    c = claims()
    assert (f"typical case with diagnostics, time(old) / time(new) was {c['one']} on the rows whose pattern was "
            f"one vector (float32 rows of 2, 4 and 8 sensors, float64 rows of 2 and 4), which then read "
            f"{c['one_floor']} of the floor (paired), and {c['six_twelve']} on float64 rows of 6 and 12; every other "
            f"case, the controls (rows of 10) among them, read {c['rest']}") in PAGE
    assert (f"typical case with diagnostics ran {c['one']} times as fast on float32 rows of 2, 4 and 8 sensors and "
            f"float64 rows of 2 and 4 (both levels; every other case {c['rest']})") in README


def test_the_kernels_alone():
    c = claims()
    first = {(m[1], int(m[2]), m[3]): m[4] for m in re.finditer(
        r"^Avx512 (f32|f64) +(\d+) (\w+) \| +([\d.]+) ", _part("'A' (patterns of at most 32 bits"), re.M)}
    slow = sorted((first[("f32", n, "typical")] for n in (4, 8)), key=float)
    assert (f"typical float32 rows of 4 and 8 with diagnostics ran at {slow[0]}-{slow[1]} GB/s against "
            f"{first[('f32', 5, 'typical')]} for rows of 5") in PAGE
    assert f"typical float32 rows: {slow[0]}-{slow[1]} GB/s against {first[('f32', 5, 'typical')]})" in README
    assert (f"typical rows with diagnostics ran {c['alone512']} times as fast at AVX-512 and {c['alone2']} at AVX2 "
            f"on those widths, float64 rows of 6 and 12 {c['alone612']}") in PAGE
    assert f"f64 rows of 2 and 4 and f32 rows of 2, 4 and 8 ran {c['alone512']} times as fast at AVX-512" in BOUNDS


def test_why_six_vectors_and_avx2_screening_unrepeated():
    c = claims()
    assert f"screened through memory at {c['a_scr']} of the speed of one-vector periods" in BOUNDS
    assert f"with them, AVX2 screened rows of 4 sensors through memory at {c['c_scr']} of the speed without" in BOUNDS
    assert (f"eight vectors screened float64 rows of 4 through memory at {c['a_scr']} of the session start's "
            f"speed; four vectors ('B') screened float64 rows of 2 and 4 at {c['b_scr']} of the speed of eight but "
            f"diagnosed typical float64 rows of 3 and 12 at {c['b_diag']} of that of six") in PAGE
    assert f"AVX2 screened rows of 4 at {c['c_scr']} of the session start's speed" in PAGE


def _intervals_from_memory() -> dict[str, str]:
    kept = _runs("'M4f32' through falsify, run 1", "'M4f32' through falsify, run 2")
    assert len(kept) == 2 * 6 * 2 * 2
    gain = [r for r in kept if r[1] == "f32" and r[2] == "typical" and r[0] in (4, 6, 8, 12)]
    both = _alone("'M4' (periods of up to four vectors, both dtypes), the kernels alone, 3 rounds")
    f64_alone = [r[4] for r in both if r[0] == "Avx2" and r[1] == "f64" and r[2] in (3, 4, 5, 6)]
    return {
        "gain": _span(r[5] for r in gain),
        "rest": _span(r[5] for r in kept if r not in gain),
        "f64_alone": _span(f64_alone),
    }


def test_the_intervals_read_from_memory():
    c = _intervals_from_memory()
    doc = " ".join((ROOT / "rust" / "src" / "simd" / "periodic.rs").read_text().replace("///", "").split())
    assert f"and 12 ran {c['gain']} times as fast through `falsify` with it" in doc
    assert f"did not change, ran {c['f64_alone']} times as fast alone" in doc
    assert (f"typical float32 rows of 4, 6, 8 and 12 sensors with diagnostics ran {c['gain']} times as fast "
            f"(two runs; every other case {c['rest']},") in PAGE
    assert f"float64 periods of five and six vectors, whose loops did not change, ran {c['f64_alone']}" in PAGE
    assert f"AVX2's typical float32 rows of 4-12 sensors with diagnostics {c['gain']} times as fast" in README


SHORT_ALONE = re.compile(r"^(Avx2|Avx512) (f32|f64) (\d+) (\w+) (?:[\d.]+ )?([\d.]+)/([\d.]+)$", re.M)


def _split_56() -> dict[str, str]:
    every = [(m[1], m[2], int(m[3]), m[4], float(m[5]))
             for m in SHORT_ALONE.finditer(_part("then: 112-bit strings (float32 rows of 7 and 14) split at bit 56"))]
    typical = lambda level: [r[4] for r in every  # noqa: E731
                             if r[0] == level and r[1] == "f32" and r[2] in (7, 14) and r[3] == "typical"]
    kept = _runs("'S56' at AVX2 only through falsify, AVX2, run 1", "'S56' at AVX2 only through falsify, AVX-512, run 1",
                 "'S56' at AVX2 only through falsify, AVX2, run 2", "'S56' at AVX2 only through falsify, AVX-512, run 2")
    assert len(kept) == 4 * 3 * 2 * 2
    avx2 = _runs("'S56' at AVX2 only through falsify, AVX2, run 1", "'S56' at AVX2 only through falsify, AVX2, run 2")
    gain = [r for r in avx2 if r[1] == "f32" and r[2] == "typical" and r[0] in (7, 14)]
    return {
        "alone2": _span(typical("Avx2")),
        "alone512": _span(typical("Avx512")),
        "gain": _span(r[5] for r in gain),
        "rest": _span(r[5] for r in kept if r not in gain),
    }


def test_rows_of_7_and_14_split_at_56():
    c = _split_56()
    doc = " ".join((ROOT / "rust" / "src" / "simd" / "periodic.rs").read_text().replace("///", "").split())
    assert f"typical rows ran {c['alone2']} times as fast at AVX2 and {c['alone512']} at AVX-512" in doc
    assert (f"typical float32 rows of 7 and 14 sensors with diagnostics ran {c['gain']} times as fast at AVX2 "
            f"(two runs; every other case, at both levels, {c['rest']})") in PAGE
    assert f"AVX2's typical float32 rows of 7 and 14 with diagnostics {c['gain']} times as fast" in README
