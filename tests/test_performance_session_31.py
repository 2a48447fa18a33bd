"""Session 31's figures in docs/performance.md, the README and the AVX2 short-row
kernels' docs (rust/src/simd/medium_avx2_short.rs, medium_avx2_screen.rs),
recomputed from the runs recorded in benches/results-short-rows.txt, section
"session 31: the AVX2 rows of 9-32 sensors": the final code alone on one core
against the session start, through memory, and the tries on the way."""

import re
import statistics

from test_performance_session_29 import PAGE, README, ROOT, SHORT_ROWS, _span
from test_performance_session_29 import _section as _section_of

SECTION = _section_of("session 31: the AVX2 rows of 9-32 sensors", SHORT_ROWS)
SHORT_DOC = " ".join((ROOT / "rust" / "src" / "simd" / "medium_avx2_short.rs").read_text()
                     .replace("//!", "").replace("///", "").replace("//", "").split())
SCREEN_DOC = " ".join((ROOT / "rust" / "src" / "simd" / "medium_avx2_screen.rs").read_text()
                      .replace("//!", "").replace("///", "").split())
# Paired lines of core_kernels_pair.py: level, dtype, width, case, then each build's diag/scr ratios.
LINE = re.compile(r"^(Avx2|Avx512) (f32|f64) +(\d+) (\w+) \|[^\n]*?\| ((?:\w+ [\d.]+/[\d.]+ ?)+)$", re.M)
SHORT = {"f32": {9, 17, 25, 31}, "f64": {9, 13, 17}}
LONGER = {"f32": {33, 50}, "f64": {33, 50}}


def _part(heading: str) -> str:
    return SECTION.split("--- " + heading)[1].split("\n--- ")[0].split("\nReading")[0]


def _ratios(block: str, build: str, widths: dict, cases=("worst", "singles", "typical"), level="Avx2"):
    """(diag, scr) paired ratios of `build` on the lines of `widths` and `cases`."""
    found = []
    for m in LINE.finditer(block):
        if m[1] == level and int(m[3]) in widths.get(m[2], set()) and m[4] in cases:
            ratios = dict(re.findall(r"(\w+) ([\d.]+/[\d.]+)", m[5]))
            found.append(tuple(float(x) for x in ratios[build].split("/")))
    return found


def _final_alone(widths, cases):
    runs = [_part(f"the final code alone, run {k}") for k in (1, 2)]
    found = [r for run in runs for r in _ratios(run, "new", widths, cases)]
    assert len(found) == 2 * sum(len(v) for v in widths.values()) * len(cases)
    return found


def claims_alone() -> dict[str, str]:
    worst = _final_alone(SHORT, ("worst",))
    others = _final_alone(SHORT, ("singles", "typical"))
    f64_17 = _final_alone({"f64": {17}}, ("singles", "typical"))
    longer = _final_alone(LONGER, ("worst", "singles", "typical"))
    return {
        "worst": _span(d for d, _ in worst),
        "others": _span(d for d, _ in others),
        "f64_17": _span(d for d, _ in f64_17),
        "screened": _span(s for _, s in worst + others),
        "longer_diag": _span(d for d, _ in longer),
        "longer_screened": _span(s for _, s in longer),
    }


MEMORY = re.compile(r"^(base|step|final) (f\d\d rows of \d+, \w+), (falsify|halves) (diag|scr): ([\d. ]+); "
                    r"median ([\d.]+)$", re.M)


def _memory(heading: str) -> dict[tuple[str, str, str], float]:
    found = {}
    for m in MEMORY.finditer(_part(heading)):
        runs = [float(x) for x in m[5].split()]
        assert abs(statistics.median(runs) - float(m[6])) < 1e-9, m[0]
        found[(m[1], m[2], f"{m[3]} {m[4]}")] = statistics.median(runs)
    return found


def claims_memory() -> dict[str, str]:
    a, b = _memory("through memory, set A"), _memory("through memory, set B")
    assert len(a) == 3 * 6 * 4 and len(b) == 2 * 6 * 4
    pick = lambda s, build, method: [v for (bb, _, mm), v in s.items() if bb == build and mm == method]  # noqa: E731
    both = lambda build, method: pick(a, build, method) + pick(b, build, method)  # noqa: E731
    out = {f"{build} {method}": _span(both(build, method))
           for build in ("base", "final") for method in ("falsify diag", "falsify scr")}
    pairs = [(v, s[("base",) + k[1:]]) for s in (a, b) for k, v in s.items() if k[0] == "final"]
    out["higher"] = f"{sum(final > base for final, base in pairs)} of the {len(pairs)}"
    return out


def test_the_final_code_alone():
    c = claims_alone()
    claim = (f"every row a candidate, ran {c['worst']} times as fast; in the two other cases "
             f"{c['others']} (float64 rows of 17 {c['f64_17']}); screened {c['screened']}")
    assert claim in PAGE and claim in README
    assert f"rows of 33 and 50 sensors (the longer rows' loop) {c['longer_diag']} with diagnostics and " \
           f"{c['longer_screened']} screened" in PAGE
    assert f"ran {c['worst']} times as fast in the worst case and {c['others']} in the others" in SHORT_DOC
    assert f"screened {c['screened']} times as fast" in SCREEN_DOC


def test_the_final_code_through_memory():
    c = claims_memory()
    claim = (f"with diagnostics {c['final falsify diag']} of the floor against {c['base falsify diag']}, "
             f"screened {c['final falsify scr']} against {c['base falsify scr']}")
    assert claim in PAGE and claim in README
    assert f"higher in {c['higher']} pairs" in PAGE


def test_the_tries_on_the_way():
    tries = _part("tries on the way")
    regs = _ratios(tries.split("then the intervals read")[0], "new", {"f32": {17, 25}, "f64": {9, 17}})
    assert len(regs) == 4 * 3
    assert f"with the intervals held in registers ({_span(d for d, _ in regs)} alone" in PAGE
    v7 = tries.split("then blocks of candidates")[1]
    slower = _ratios(v7, "v7", {"f32": {9, 17, 25}, "f64": {9, 17}}, ("singles", "typical"))
    assert len(slower) == 5 * 2
    claim = f"{_span(d for d, _ in slower)} times as fast"
    assert f"rows of few candidates ran {claim}" in SHORT_DOC and f"the other cases {claim}" in PAGE


SIDE_BY_SIDE = re.compile(r"^ +(\d+) (f32|f64) +(\w+) +(diag|scr) .*old/new paired ([\d.]+)$", re.M)


def test_side_by_side_through_falsify():
    runs = SECTION.split("--- through falsify, side by side")[1:]
    assert len(runs) == 3
    rows = [(int(m[1]), m[2], m[4], float(m[5])) for run in runs
            for m in SIDE_BY_SIDE.finditer(run.split("\nReading")[0])]
    assert len(rows) == 24 + 8 + 24
    pick = lambda keep: [r for n, d, mode, r in rows if keep(n, d, mode)]  # noqa: E731
    screened = pick(lambda n, d, mode: mode == "scr" and n >= 17)
    f32_9 = _span(pick(lambda n, d, mode: (n, d) == (9, "f32")))
    f64_9 = _span(pick(lambda n, d, mode: (n, d) == (9, "f64")))
    f32_diag = _span(pick(lambda n, d, mode: n in (17, 25) and d == "f32" and mode == "diag"))
    f64_17 = _span(pick(lambda n, d, mode: (n, d, mode) == (17, "f64", "diag")))
    rows_50 = _span(pick(lambda n, d, mode: n == 50 and mode == "diag"))
    controls = _span(pick(lambda n, d, mode: n in (10, 16)))
    below = f"below 1 in {sum(r < 1 for r in screened)} of the {len(screened)} cases"
    assert f"time(old) / time(new) was {f32_9} for float32 rows of 9, {f64_9} for float64 rows of 9 and " \
           f"{f32_diag} for float32 rows of 17 and 25 with diagnostics, but {f64_17} for float64 rows of 17 with " \
           f"diagnostics, and screened rows of 17 sensors and more read {_span(screened)}, {below}" in PAGE
    assert f"Rows of 50 with diagnostics (the longer rows' loop) read {rows_50}, the periodic widths 10 and 16 " \
           f"(controls, not changed) {controls}" in PAGE
    assert f"was {f32_9} for float32 rows of 9, but screened rows of 17 sensors and more read {_span(screened)} " \
           f"and float64 rows of 17 with diagnostics {f64_17}" in README
    reading = " ".join(SECTION.split("\nReading: side by side in one process")[1].split())
    assert f"time(old) / time(new) {_span(screened)} there, {below}" in reading
