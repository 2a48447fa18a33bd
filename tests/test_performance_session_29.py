"""Session 29's figures in docs/performance.md and the AVX2 medium kernel's doc
(rust/src/simd/medium_avx2.rs), recomputed from the runs recorded in
benches/results-long-rows.txt: the kernels through memory without Python
(cargo bench --bench core_memory), the order rows are read in, the row pairs as
distant streams, the AVX2 f64 counters and the row-batch widths."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LONG_ROWS = (ROOT / "benches" / "results-long-rows.txt").read_text()
SHORT_ROWS = (ROOT / "benches" / "results-short-rows.txt").read_text()
PAGE = " ".join((ROOT / "docs" / "performance.md").read_text().split())
README = " ".join((ROOT / "README.md").read_text().split())
MEDIUM_DOC = " ".join((ROOT / "rust" / "src" / "simd" / "medium_avx2.rs").read_text().replace("///", "").split())
MEDIAN = re.compile(r"^  (\S.*?)\s+speed / floor ([\d.]+) \(", re.M)
PAIR = re.compile(r"^(Avx2|Avx512) (f32|f64) +(\d+) (\w+) \|.*\| new ([\d.]+)/([\d.]+)$", re.M)


def _section(title: str, text: str = LONG_ROWS) -> str:
    found = [s for s in text.split("\n=== ") if s.startswith(title)]
    assert len(found) == 1, title
    return found[0]


def _span(values) -> str:
    values = list(values)
    assert values
    return f"{min(values):.2f}-{max(values):.2f}"


def _medians(block: str) -> dict[str, list[float]]:
    found: dict[str, list[float]] = {}
    for m in MEDIAN.finditer(block):
        found.setdefault(m[1], []).append(float(m[2]))
    return found


def _case(block: str, title: str) -> str:
    """The lines of one case ("f64 rows of 200, worst") of a core_memory run."""
    return block.split(title + ":")[1].split("\nf")[0].split("\nReading")[0]


def test_the_pool_costs_nothing_measurable():
    section = _section("session 29: the kernels through memory without Python").split("\nReading")[0]
    medians = _medians(section)
    assert sorted(medians) == ["falsify diag", "falsify scr", "halves diag", "halves scr"]
    values = [v for vs in medians.values() for v in vs]
    assert len(values) == 4 * 5  # run 1's worst and typical case, three runs' worst case
    assert f"both ways read float64 rows of 200 at {_span(values)} of the floor by the median" in PAGE
    floors = [float(x) for x in re.findall(r"floor [\d.]+ ms \(([\d.]+)-", section)]
    assert f"The floor read no faster than {min(floors)} ms in these runs" in PAGE


def test_the_order_rows_are_read_in():
    runs = _section("session 29: the order rows are read in").split("--- run ")[1:3]
    m = [_medians(_case(run, "f64 rows of 200, worst")) for run in runs]
    get = lambda name: [v for x in m for v in x[name]]  # noqa: E731
    assert f"interleaved, vector by vector (the kernels' order) at {_span(get('pairs'))} of the floor, " \
           f"{_span(get('pairs pf'))} with the kernels' prefetch" in PAGE
    in_order = get("seq") + get("seq pf") + get("split") + get("split pf")
    assert f"two distant sequential streams at {_span(in_order)}" in PAGE
    pairs = _section("session 29: the kernels reading row pairs")
    split = [float(x) for x in re.findall(r"split\s+speed / floor ([\d.]+)", pairs)]
    adjacent = [float(x) for x in re.findall(r"adjacent\s+speed / floor ([\d.]+)", pairs)]
    assert len(split) == len(adjacent) == 12
    assert f"they read {_span(split)} of the floor, adjacent pairs {_span(adjacent)}" in PAGE
    assert max(adjacent) >= max(split) and min(adjacent) >= min(split)


def test_the_avx2_f64_counter_figures():
    runs = _section("session 29: AVX2 f64 counters").split("--- run ")[1:]
    assert len(runs) == 3
    lines = [[m.groups() for m in PAIR.finditer(run)] for run in runs]
    diag = lambda level, dtype, sizes, which=(0, 1, 2): [  # noqa: E731
        float(g[4]) for i in which for g in lines[i] if g[0] == level and g[1] == dtype and g[2] in sizes]
    f64 = _span(diag("Avx2", "f64", ("33", "50")))
    f64_64 = _span(diag("Avx2", "f64", ("64",)))
    f32 = _span(diag("Avx2", "f32", ("33", "50", "64"), (2,)))
    controls = _span(diag("Avx512", "f32", ("17", "33", "50", "64")) + diag("Avx512", "f64", ("17", "33", "50", "64")))
    assert f"rows of 33 and 50 with diagnostics ran {f64} times as fast, rows of 64 {f64_64}, float32 rows " \
           f"(their code as before) {f32}; the unchanged AVX-512 kernels in the same binaries read {controls}" in PAGE
    # The doc's own figures (its section is named there).
    found = re.search(r"f64 rows of 33 and 50 with diagnostics then ran ([\d.]+)-([\d.]+) times as fast, "
                      r"f32 rows \(unchanged code\) ([\d.]+)-([\d.]+)", MEDIUM_DOC)
    assert found and f"{found[1]}-{found[2]}" == f64 and f"{found[3]}-{found[4]}" == f32
    assert re.search(r"46 stack moves a row for rows of 50, 28 now", MEDIUM_DOC)
    assert "46 moves a row for rows of 50" in PAGE and "28 moves a row" in PAGE


def test_the_row_batch_widths():
    section = _section("session 29: the widths the row-batch kernel takes")
    alone = {(d, int(n), c): float(v) for d, n, c, v in
             re.findall(r"(f32|f64) (\d+) (worst|typical) d=([\d.]+)", section)}
    periodic = [(d, n) for d, ns in (("f32", (10, 12, 14, 20, 24, 28)), ("f64", (10, 12, 14))) for n in ns]
    batches = [(d, n) for d, ns in (("f32", (9, 11, 13, 15, 16, 17, 18, 19, 21, 22, 23, 25, 26, 27, 29, 30, 31, 32)),
                                    ("f64", (8, 9, 11, 13, 15, 16))) for n in ns]
    assert len(alone) == 2 * (24 + 9)
    worst = lambda cases: [alone[(d, n, "worst")] for d, n in cases]  # noqa: E731
    assert f"read {min(worst(periodic)):.1f}-{max(worst(periodic)):.1f} GB/s with diagnostics" in PAGE
    assert f"whose cost is per row, {min(worst(batches)):.1f}-{max(worst(batches)):.1f} GB/s" in PAGE
    assert min(worst(periodic)) > max(worst(batches[:9]))  # the shortest row-batch widths are the slow ones
    f32_17 = section.split("f32 rows of 17, worst")[1]
    worst17 = re.search(r"falsify diag\s+speed / floor ([\d.]+)", f32_17)[1]
    typical17 = re.search(r"falsify diag\s+speed / floor ([\d.]+)", f32_17.split("f32 rows of 17, typical")[1])[1]
    floor = re.search(r"f32 rows of 17, worst: floor ([\d.]+) ms", section)[1]
    assert f"float32 rows of 17 with diagnostics read {worst17} of the floor in the worst case and {typical17} in " \
           f"the typical one, with the floor at {round(float(floor))} ms" in PAGE
    avx2 = [float(v) for v in re.findall(r"Avx2 f32 +(?:17|25) \w+ +([\d.]+)", section)]
    assert len(avx2) == 4 and f"float32 rows of 17 and 25 read {min(avx2):.1f}-{max(avx2):.1f} GB/s" in PAGE


def test_the_flat_kernel_that_was_not_kept():
    section = _section("session 29: a flat kernel for the row-batch widths, not kept")
    builds = section.split("--- build ")[1:]
    assert len(builds) == 5  # four builds and build 2 taken apart
    flat = re.compile(r"^Avx512 (f32|f64) +\d+ \w+ \|.*\| flat ([\d.]+)/([\d.]+)$", re.M)
    paired = [float(m[2]) for b in builds if "taken apart" not in b.split("\n")[0] for m in flat.finditer(b)]
    assert paired and max(paired) < 1
    assert f"ran {_span(paired)} times as fast as the row-batch kernel with diagnostics in four builds" in PAGE


def test_the_readme_paragraph_matches_the_page():
    """The README's session-29 figures are the page's (each checked above against the runs)."""
    paragraph = README.split("Session 29 measured widths the floor table leaves out")[1].split("## ")[0]
    for figure in re.findall(r"\d+\.\d+(?:-\d+\.\d+)?", paragraph):
        assert figure in PAGE, figure
    assert "read 18.6-48.9 GB/s with diagnostics in the worst case, against 46.0-79.9" in paragraph
    assert "float32 rows of 17 with diagnostics read 0.80 of the floor in the worst case and 0.66" in paragraph
    assert "float64 rows of 33 and 50 with diagnostics ran 1.06-1.08 times as fast alone" in paragraph


def test_the_row_batches_prefetch_hint():
    section = _section("session 29: the row batches' prefetch hint", SHORT_ROWS)
    change = section.split("--- the change")[1].split("--- through memory")[0]
    lines = [m.groups() for m in re.finditer(
        r"^(Avx2|Avx512) (f32|f64) +(\d+) (\w+) \|.*\| const ([\d.]+)/([\d.]+)$", change, re.M)]
    assert len(lines) == 2 * 9 * 2
    avx512 = [(float(g[4]), float(g[5])) for g in lines if g[0] == "Avx512"]
    avx2 = [float(v) for g in lines if g[0] == "Avx2" for v in g[4:]]
    diag, screened = _span(d for d, _ in avx512), _span(s for _, s in avx512)
    assert min(d for d, _ in avx512) > 1 and min(s for _, s in avx512) > 1
    assert f"the row-batch widths ran {diag} times as fast with diagnostics and {screened} screened, the AVX2 " \
           f"kernels, not touched, {_span(avx2)}" in PAGE
    assert f"then ran them {diag} times as fast with diagnostics alone" in README
    doc = " ".join((ROOT / "rust" / "src" / "simd" / "row_batches.rs").read_text().replace("//", "").split())
    assert f"made these rows with diagnostics {diag} times as fast and screened {screened}" in doc
    memory = section.split("--- through memory")[1]
    floors = [float(x) for x in re.findall(r"floor [\d.]+ ms \(([\d.]+)-([\d.]+)\)", memory) for x in x]
    assert f"a slow spell of the host (the floor at {min(floors)}-{max(floors)} ms)" in PAGE
