"""Session 35's figures, recomputed from the runs recorded in
benches/results-long-rows.txt (sections "session 35: the fixed prefetch's
distance" and "session 35: the fixed prefetch t1:6144") and the floor
table's runs in benches/results-short-rows.txt ("session 35 final code",
"session 35 AVX2 final code"): the Reading lines there, the doc comment of
`Prefetch::FIXED`, the performance page and the README."""

import re
import statistics

from test_performance_session_29 import PAGE, ROOT, _section
from test_performance_session_34 import check_floor_table, check_lowest_is_avx2_rows_of_9

SCAN = _section("session 35: the fixed prefetch's distance")
SIDE = _section("session 35: the fixed prefetch t1:6144")
README = " ".join((ROOT / "README.md").read_text().split())
FIXED_DOC = " ".join((ROOT / "rust" / "src" / "simd" / "prefetch.rs").read_text().replace("///", "").replace("//!", "").split())
# One case of a core_memory scan: build (scans 2 and 3), dtype, width, case, the methods' medians.
SCAN_CASE = re.compile(r"^(?:(\S+) )?(f\d\d) rows of (\d+), (\w+): floor [\d.]+ ms(.*)$", re.M)
METHOD = re.compile(r"(?:falsify|halves) (?:diag|scr) ([\d.]+)")
# One case of paired_builds.py: width and the paired time(old) / time(new).
PAIRED = re.compile(r"^ +(\d+) f\d\d +\w+ +(?:diag|scr) .*old/new paired ([\d.]+)$", re.M)
MEDIAN = re.compile(r"^old/new paired, median over (\d+) cases: ([\d.]+) \(range ([\d.]+)-([\d.]+)\)$", re.M)


def _scan_values() -> dict[tuple[str, str, int], list[float]]:
    """Per (build, dtype, width) every method's median of every pass."""
    values: dict[tuple[str, str, int], list[float]] = {}
    build = None
    for line in SCAN.splitlines():
        if line.startswith("== "):
            build = line[3:].strip()
            continue
        m = SCAN_CASE.match(line)
        if m:
            key = (m[1] or build, m[2], int(m[3]))
            values.setdefault(key, []).extend(float(v) for v in METHOD.findall(m[5]))
    return values


def _rows_of_200(values: dict, builds: tuple[str, ...]) -> list[float]:
    """Every value of `builds` on rows of 200 (both dtypes)."""
    return [v for (b, _, n), vs in values.items() if b in builds and n == 200 for v in vs]


# The builds that prefetch nothing into L2: non-temporal, none, into L1.
AWAY = ("Nta4096", "Nta8192", "Off0", "T08192")


def test_the_distance_scan():
    values = _scan_values()
    (reading,) = [line for line in SCAN.splitlines() if line.startswith("Reading:")]
    words = " ".join(reading.split())
    away = _rows_of_200(values, AWAY)
    # Four builds, two passes, two dtypes, two cases, four methods.
    assert len(away) == 4 * 2 * 2 * 2 * 4
    assert f"these kernels read rows of 200 at {min(away):.2f}-{max(away):.2f} of the floor" in words
    names = {"T14096": "t1:4096", "T15120": "t1:5120", "T16144": "t1:6144", "T17168": "t1:7168", "base": "t1:8192 (base)",
             "T112288": "t1:12288", "T116384": "t1:16384", "T28192": "t2:8192", "T216384": "t2:16384"}
    medians = {}
    for build, name in names.items():
        f32, f64 = (statistics.median(values[(build, dt, 200)]) for dt in ("f32", "f64"))
        medians[build] = (f32, f64)
        assert f"{name} {f32:.3f} / {f64:.3f}" in words, name
    # t1:6144: the best on float32 rows of 200, and as good as t1:8192 on float64 ones.
    assert max(medians, key=lambda b: medians[b][0]) == "T16144"
    assert f"{medians['T16144'][1]:.3f}" == f"{medians['base'][1]:.3f}"
    assert "t1:6144 is the best on float32 rows and ties t1:8192 on float64 rows" in words
    # The doc comment's summary of the scan.
    assert medians["T14096"][1] < medians["base"][1] - 0.1 and "4 KiB slowed f64 rows of 200 there" in FIXED_DOC
    base = _rows_of_200(values, ("base",))
    assert statistics.median(away) < 0.6 * statistics.median(base) and "none or into L1 halved their speed" in FIXED_DOC


def _runs(level: str) -> list[str]:
    parts = SIDE.split("\n--- ")[1:]
    return [p for p in parts if p.startswith(f"{level}, run")]


def test_side_by_side():
    (reading,) = [line for line in SIDE.splitlines() if line.startswith("Reading:")]
    words = " ".join(reading.split())
    spans = {}
    for level in ("AVX-512", "AVX2"):
        runs = _runs(level)
        assert len(runs) == 2
        printed = []
        for run in runs:
            cases = [float(m[2]) for m in PAIRED.finditer(run)]
            (m,) = MEDIAN.findall(run)
            # The script's own median and range are those of its cases (its
            # median of unrounded ratios may differ in the last digit).
            assert int(m[0]) == len(cases) == 96
            assert abs(statistics.median(cases) - float(m[1])) <= 0.0015
            assert f"{min(cases):.3f}" == m[2] and f"{max(cases):.3f}" == m[3]
            printed.append(m[1])
        cases = [(int(m[1]), float(m[2])) for run in runs for m in PAIRED.finditer(run)]
        long_rows = [r for n, r in cases if n >= 25]
        short_rows = [r for n, r in cases if n <= 16]
        assert len(long_rows) == len(short_rows) == 96
        spans[level] = [f"{statistics.median(v):.3f} ({min(v):.3f}-{max(v):.3f})" for v in (long_rows, short_rows)]
        assert f"{level} {printed[0]} and {printed[1]}" in words
    assert (f"rows of 25-200 sensors (the medium and long-row kernels), {spans['AVX-512'][0]} at AVX-512 and "
            f"{spans['AVX2'][0]} at AVX2; rows of 4-16, {spans['AVX-512'][1]} at AVX-512") in words
    assert f"and {spans['AVX2'][1]} at AVX2" in words
    long512, long2 = (spans[level][0].split()[0] for level in ("AVX-512", "AVX2"))
    assert f"sensors {long512} (AVX-512) and {long2} (AVX2) times as fast by the median" in FIXED_DOC
    for text in (PAGE, README):
        assert f"rows of 25-200 sensors {long512} times as fast at AVX-512 and {long2} at AVX2" in text


def test_the_scan_in_the_docs():
    values = _scan_values()
    away = _rows_of_200(values, AWAY)
    span = f"{min(away):.2f}-{max(away):.2f}"
    assert f"these kernels read rows of 200 at {span} of the floor with no prefetch, into L1 or non-temporal" in PAGE
    assert f"with none, into L1 or non-temporal, rows of 200 read {span} of the floor" in README
    f32 = {b: statistics.median(values[(b, "f32", 200)]) for b in ("T14096", "T15120", "T16144", "T17168", "base")}
    f64 = {b: statistics.median(values[(b, "f64", 200)]) for b in f32}
    assert max(f32, key=f32.get) == "T16144" and min(f64, key=f64.get) == "T14096"
    assert "into L2, 4 KiB ahead slowed float64 rows of 200 and 6 KiB read float32 rows of 200 best" in PAGE


def test_the_session_35_floor_table():
    """Session 35's table (the README's until session 36), on the page: six
    runs at each level, the floors, the misses, the lowest case."""
    texts = [(ROOT / "docs" / "performance.md").read_text()]
    a512, avx2, words = check_floor_table("35", texts)
    check_lowest_is_avx2_rows_of_9(a512, avx2, [words, PAGE])
