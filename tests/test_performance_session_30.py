"""Session 30's figures in docs/performance.md, the README and the AVX2 medium
kernel's doc (rust/src/simd/medium_avx2.rs), recomputed from the runs recorded
in benches/results-short-rows.txt: the row-batch widths through memory, and
"falsified only by" in the AVX2 medium kernel (a branch, not kept; vector
counters, kept), and the row batches' masks read a batch later."""

import re

# The pages, results and patterns session 29's checks read, read the same way.
from test_performance_session_29 import MEDIUM_DOC, PAGE, PAIR, README, SHORT_ROWS, _span
from test_performance_session_29 import ROOT, _section as _section_of

CASE = re.compile(r"^(f32|f64) rows of (\d+), (worst|typical): floor ([\d.]+) ms.*\n((?:  .*\n?){4})", re.M)


def _section(title: str) -> str:
    return _section_of(title, SHORT_ROWS)


def _median(lines: str, method: str) -> float:
    return float(re.search(rf"{method}\s+speed / floor ([\d.]+)", lines)[1])


def _part(section: str, heading: str) -> str:
    """The lines after the `--- heading...` line, up to the next `---` or `Reading`."""
    return section.split("--- " + heading)[1].split("\n--- ")[0].split("\nReading")[0]


def _diag_ratios(block: str, level: str, widths: dict[str, set[int]]) -> list[float]:
    return [float(m[5]) for m in PAIR.finditer(block)
            if m[1] == level and int(m[3]) in widths.get(m[2], set())]


def test_the_row_batch_widths_through_memory():
    section = _section("session 30: the row-batch widths through memory")
    runs = [_part(section, f"run {k}") for k in (1, 2, 3)]
    cases = [(run, m) for run in runs for m in CASE.finditer(run)]
    assert len(cases) == 8 + 6 + 8
    avx512 = [(m, float(m[4])) for run, m in cases if run is not runs[2]]
    widths = {("f32", "17"), ("f32", "25"), ("f64", "9")}
    slow = [_median(m[5], method) for m, floor in avx512 if (m[1], m[2]) in widths and 24 <= floor <= 26.5
            for method in ("falsify diag", "falsify scr")]
    assert len(slow) == 14
    fast = [_median(m[5], "falsify diag") for m, floor in avx512 if floor < 19 and m[3] == "typical"]
    assert len(fast) == 3
    avx2 = [m for run, m in cases if run is runs[2] and (m[1], m[2]) in widths]
    diag, screened = ([_median(m[5], f"falsify {x}") for m in avx2] for x in ("diag", "scr"))
    assert f"read {_span(slow)} of the floor, screened or with diagnostics, where the floor read the 800 MB in " \
           f"24-26 ms; where it read in 15-19 ms, typical rows with diagnostics read {_span(fast)}" in PAGE
    assert f"diagnostics read only {_span(diag)} (screened {_span(screened)})" in PAGE
    assert f"at AVX-512 they read {_span(slow)} of the floor where it read in 24-26 ms, at AVX2 with " \
           f"diagnostics {_span(diag)}" in README


def test_vector_counters_for_falsified_only_by():
    section = _section("session 30: falsified only by")
    kept = _part(section, "the change kept")
    short = {"f32": {17, 25}, "f64": {9, 17}}
    alone = _diag_ratios(kept, "Avx2", short)
    assert len(alone) == 4 * 3  # four widths, three cases
    claim = f"ran {_span(alone)} times as fast"
    assert claim in MEDIUM_DOC and claim in PAGE and claim in README
    memory = _part(section, "through memory, the change kept")
    medians = {label: [float(x) for line in memory.splitlines() if line.startswith(label + " ")
                       for x in re.findall(r"ms ([\d.]+) \(", line)] for label in ("base", "alone")}
    assert [len(v) for v in medians.values()] == [16, 16]
    claim = f"{_span(medians['alone'])} of the floor against {_span(medians['base'])}"
    assert claim in MEDIUM_DOC and claim in PAGE
    assert f"read {_span(medians['alone'])} of the floor through memory against {_span(medians['base'])}" in README
    higher = sum(a > b for a, b in zip(medians["alone"], medians["base"]))
    assert f"higher in {higher} of the 16 pairs" in section


def test_the_branch_that_was_not_kept():
    section = _section("session 30: falsified only by")
    branch = _part(section, "a branch on the row's count")
    up_to_seven = {"f32": {17, 25, 33, 50}, "f64": {9, 17, 25}}
    ratios = _diag_ratios(branch, "Avx2", up_to_seven)
    assert len(ratios) == 7 * 3
    assert f"A branch on the row's count instead of the add ran {_span(ratios)} times as fast alone" in PAGE
    lines = [m for m in PAIR.finditer(branch) if m[1] == "Avx2" and int(m[3]) in up_to_seven[m[2]]]
    steady, singles = ([float(m[5]) for m in lines if (m[4] == "singles") == s] for s in (False, True))
    assert f"the AVX2 medium kernel's rows of 2-7 vectors {_span(steady)} times as fast " \
           f"({_span(singles)} with half the rows rejected by one sensor)" in " ".join(section.split())


def test_the_row_batches_masks_read_a_batch_later():
    section = _section("session 30: the row batches' masks read a batch later")
    kept = _part(section, "the change kept")
    row_batch = {"f32": {9, 17, 25, 31}, "f64": {9, 16}}
    diag = _diag_ratios(kept, "Avx512", row_batch)
    assert len(diag) == 6 * 3
    claim = f"ran {_span(diag)} times as fast"
    assert claim + " deferred (AMD EPYC Zen 4" in " ".join(
        (ROOT / "rust" / "src" / "simd" / "row_batches.rs").read_text().replace("//", "").split())
    assert f"the last in the floor table) {claim}" in PAGE
    assert f"those widths with diagnostics {claim} alone" in README
    memory = _part(section, "through memory")
    slow = [float(m[2]) for m in re.finditer(r"floor ([\d.]+) ms \(.*?falsify diag\s+speed / floor ([\d.]+)", memory)
            if float(m[1]) > 23]
    fast = [float(m[2]) for m in re.finditer(r"typical: floor ([\d.]+) ms \(.*?falsify diag\s+speed / floor ([\d.]+)",
                                             memory) if float(m[1]) < 18]
    assert len(slow) == 20 and len(fast) == 3
    assert f"where the floor read in 23-29 ms, the two builds both read {_span(slow)} of it" in PAGE
    assert f"met the fast floor where the old one was short ({_span(fast)}, typical" in PAGE
    tries = _part(section, "first, two other tries")
    medium = [float(m[3]) for m in re.finditer(r"^Avx512 (f32|f64) +(\d+) \w+ \|.*\| m512 ([\d.]+)/", tries, re.M)
              if int(m[2]) in {"f32": {33, 50, 64}, "f64": {17, 25, 32}}[m[1]]]
    assert len(medium) == 6 * 3
    assert f"vector counters ({_span(medium)})" in PAGE


def test_the_avx2_intervals_in_registers():
    section = _section("session 30: the AVX2 intervals in registers")
    alone = _part(section, "alone on one core")
    diag = _diag_ratios(alone, "Avx2", {"f32": {17, 25, 33, 50, 64}, "f64": {9, 17, 25, 33, 50, 64}})
    assert len(diag) == 11 * 3
    claim = f"ran {_span(diag)} times as fast"
    code = " ".join((ROOT / "rust" / "src" / "simd" / "medium_avx2.rs").read_text().replace("//", "").split())
    assert f"rows of 9-64 sensors with diagnostics {claim}" in code
    assert f"rows of 9-64 sensors with diagnostics {claim} alone" in PAGE
    memory = _part(section, "through memory")
    medians = {label: [float(x) for x in re.findall(rf"^{label} .*speed / floor ([\d.]+)", memory, re.M)]
               for label in ("head", "regs")}
    assert [len(v) for v in medians.values()] == [12, 12]
    assert f"read {_span(medians['regs'])} of the floor against {_span(medians['head'])} before" in PAGE
    higher = sum(a > b for a, b in zip(medians["regs"], medians["head"]))
    assert f"'regs' higher in {higher} of the 12 pairs" in section
