"""Session 20's figures in docs/performance.md ("AMD EPYC of CPU family 25
(session 20)"): the floor tables, the kernels alone and the AVX2 medium
kernel's side by side, recomputed from the runs recorded in
benches/results-short-rows.txt and benches/results-long-rows.txt."""

import re
import statistics
from pathlib import Path

from test_performance_tables import ROW, _cases_table, _floor_summary, _target

ROOT = Path(__file__).resolve().parent.parent


def _page() -> str:
    return " ".join((ROOT / "docs" / "performance.md").read_text().split())


def _runs(text: str, prefix: str) -> list[str]:
    runs = [s for s in text.split("\n=== ") if s.startswith(prefix)]
    assert len(runs) == 3, prefix
    return runs


def _misses(*levels: list[str]) -> tuple[int, int]:
    """Medians below the issue's targets, and medians, over the levels' runs."""
    medians = [statistics.median(v) for runs in levels for k, v in _cases_table(runs).items()
               if statistics.median(v) < _target(k[0], k[2], k[3])]
    return len(medians), sum(len(_cases_table(runs)) for runs in levels)


def _alternating(text: str, start: str, end: str, labels: str, line: str) -> dict:
    """Per (build, case), the rates of the runs between the section headers
    `start` and `end`, whose sub-runs are headed "=== <label>, run N ===" and
    whose rates match `line` (case, rate)."""
    section = text.split(start)[1].split(end)[0]
    parts = re.split(rf"^=== ({labels}), run \d ===$", section, flags=re.M)
    rates = {}
    for build, body in zip(parts[1::2], parts[2::2]):
        for name, r in re.findall(line, body, re.M):
            rates.setdefault((build, name), []).append(float(r))
    return rates


def test_session_20_floor_figures_match_the_recorded_runs():
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    page = _page()
    start512, start2 = _runs(text, "session 20 start, run"), _runs(text, "session 20 start AVX2,")
    medium2 = _runs(text, "session 20 AVX2 medium kernel,")
    missed, total = _misses(start512, start2)
    missed_19, total_19 = _misses(_runs(text, "session 19 final code"), _runs(text, "session 19 AVX2 final code"))
    assert total == total_19 == 80
    assert (f"missed the targets in {missed} of the {total} medians where session 19's runs missed {missed_19}"
            in page)
    floors = [float(m[5]) for run in start512 + start2 + medium2 for m in map(ROW.match, run.splitlines())
              if m and m[4] == "diagnostics"]
    fast = [f for f in floors if f < 17]
    assert (f"In these nine runs the floor read the 800 MB in {min(floors):.1f}-{max(floors):.1f} ms (median "
            f"{statistics.median(floors):.1f}), under 17 ms (more than 47 GB/s) in {len(fast)} of the "
            f"{len(floors)} cases timed") in page
    assert 800 / min(floors) > 60  # "At 13 ms it reads about 60 GB/s"

    def by_run(key):
        return [(float(m[5]), float(m[6])) for run in medium2 for m in map(ROW.match, run.splitlines())
                if m and (m[1], m[2], m[3], m[4]) == key]

    (f1, r1), _, (f3, r3) = by_run(("16", "f32", "typical", "diagnostics"))
    assert (f"the same kernel reads {r1:.2f} of the floor when the floor takes {f1:.1f} ms and {r3:.2f} when it "
            f"takes {f3:.1f} ms") in page
    rows50 = by_run(("50", "f32", "typical", "diagnostics"))
    assert (f"float32 typical read {', '.join(f'{r:.2f}' for _, r in rows50[:2])} and {rows50[2][1]:.2f} of floors "
            f"of {', '.join(f'{f:.1f}' for f, _ in rows50[:2])} and {rows50[2][0]:.1f} ms") in page
    spans = []
    for runs in (start2, medium2):
        table = _cases_table(runs)
        m = [statistics.median(v) for k, v in table.items() if k[0] == "50" and k[3] == "diagnostics"]
        spans.append(f"{min(m):.2f}-{max(m):.2f}")
    assert f"the rows of 50 with diagnostics went from {spans[0]} (the session start's runs) to {spans[1]}" in page

    # The kernels alone: per-thread read rates from the L3 cache.
    section = text.split("\n=== session 20: the kernels alone")[1].split("\n=== ")[0]
    rate = {n: float(g) for n, g in re.findall(r"^(\S+) [\d.]+ Mrows/s ([\d.]+) GB/s", section, re.M)}
    slowest = sorted((v, n) for n, v in rate.items() if "/diagnose_bits/" in n and "Portable" not in n)[:4]
    assert [n for _, n in slowest] == ["short_rows_10/typical/diagnose_bits/f32/Avx2",
                                       "short_rows_5/typical/diagnose_bits/f32/Avx512",
                                       "short_rows_16/typical/diagnose_bits/f32/Avx2",
                                       "short_rows_5/typical/diagnose_bits/f32/Avx2"]
    assert (f"float32 rows of 10 read {slowest[0][0]} GB/s at AVX2, float32 rows of 5 {slowest[1][0]} GB/s at "
            f"AVX-512, float32 rows of 16 {slowest[2][0]} GB/s at AVX2 and float32 rows of 5 {slowest[3][0]} GB/s "
            f"at AVX2") in page
    assert all(30 / v > 1.9 for v, _ in slowest)  # "about twice as fast" to test 30 GB/s a core


def test_session_20_medium_kernel_figures_match_the_recorded_runs():
    text = (ROOT / "benches" / "results-long-rows.txt").read_text()
    page = _page()
    rates = _alternating(text, "\n=== session 20: the AVX2 medium kernel (rows",
                         "\n=== session 20: the AVX2 medium kernel through", "old|new",
                         r"^long_rows_50/(\w+/diagnose/f\d\d)/Avx2 ([\d.]+) Melem/s")
    assert len(rates) == 8 and all(len(v) == 2 for v in rates.values())

    def span(build, name):
        v = rates[(build, name)]
        return f"{min(v):.1f}-{max(v):.1f}"

    for case in ("typical", "worst"):
        cells = [span(b, f"{case}/diagnose/{d}") for d in ("f32", "f64") for b in ("old", "new")]
        assert "float32 {} -> {}, float64 {} -> {}".format(*cells) in page
    assert min(rates[("new", "typical/diagnose/f32")]) > max(rates[("old", "typical/diagnose/f32")])
    assert max(rates[("new", "worst/diagnose/f64")]) < min(rates[("old", "worst/diagnose/f64")])

    paired = text.split("\n=== session 20: the AVX2 medium kernel through")[1].split("\n=== ")[0]
    ratio = {(n, d, c): float(r) for n, d, c, r in
             re.findall(r"^\s*(\d+) (f\d\d)\s+(\w+) diag .*old/new paired ([\d.]+)$", paired, re.M)}
    assert len(ratio) == 20
    medium = [v for k, v in ratio.items() if k[0] in ("50", "64")]
    controls = [v for k, v in ratio.items() if k[0] in ("12", "20", "32")]
    assert f"rows of 50 and 64 ran {min(medium):.3f}-{max(medium):.3f} times as fast" in page
    assert f"ran {min(controls):.3f}-{max(controls):.3f} times as fast: that is the noise of the comparison" in page
    best = max(ratio, key=ratio.get)
    assert best[1:] == ("f32", "typical")  # "float32 typical the most"


def test_session_20_prefetch_figures_match_the_recorded_runs():
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    page = _page()
    rates = _alternating(text, "\n=== session 20: the prefetch taken once a call (",
                         "\n=== session 20: the prefetch taken once a call, through", "base|once",
                         r"^(short_rows_5/typical/diagnose_bits/f32/Avx512) ([\d.]+) Mrows/s")
    rows5 = {b: rates[(b, "short_rows_5/typical/diagnose_bits/f32/Avx512")] for b in ("base", "once")}
    assert len(rows5["base"]) == len(rows5["once"]) == 5
    spans = {b: f"{min(v):.0f}-{max(v):.0f}" for b, v in rows5.items()}
    assert f"float32 rows of 5 with diagnostics went from {spans['base']} to {spans['once']} M rows/s" in page
    gbs = [r * 5 * 4 / 1000 for r in rows5["base"]]  # rows of 5 float32 values
    assert f"float32 rows of 5 read {min(gbs):.1f}-{max(gbs):.1f} GB/s in the five \"base\" runs" in page

    paired = text.split("\n=== session 20: the prefetch taken once a call, through falsify")[1].split("\n=== ")[0]
    ratio = {(n, d, c, mode): float(r) for n, d, c, mode, r in
             re.findall(r"^\s*(\d+) (f\d\d)\s+(\w+)\s+(diag|scr) .*old/new paired ([\d.]+)$", paired, re.M)}
    assert len(ratio) == 32
    f32_diag = {n: ratio[(n, "f32", "typical", "diag")] for n in ("5", "10", "12", "20")}
    assert (f"rows of 5 ran {f32_diag['5']:.3f} times as fast, rows of 10 {f32_diag['10']:.3f}, rows of 12 "
            f"{f32_diag['12']:.3f} and rows of 20 {f32_diag['20']:.3f}") in page
    assert all(r > 1.02 for r in f32_diag.values())
    others = [r for k, r in ratio.items() if not (k[1:] == ("f32", "typical", "diag"))]
    assert (f"the other cases ran {min(others):.3f}-{max(others):.3f} times as fast (median "
            f"{statistics.median(ratio.values()):.3f} over all 32)") in page


def test_readme_gives_session_20_figures_as_recorded():
    """The README's session 20 sentences carry the performance page's figures."""
    readme = " ".join((ROOT / "README.md").read_text().split())
    page = _page()
    span = re.search(r"In these nine runs the floor read the 800 MB in ([\d.]+-[\d.]+) ms", page)[1]
    assert f"(the 800 MB read in {span} ms)" in readme
    f32 = [float(r) for r in re.search(r"rows of 5 ran ([\d.]+) times as fast, rows of 10 ([\d.]+), rows of 12 "
                                       r"([\d.]+) and rows of 20 ([\d.]+)", page).groups()]
    assert f"ran {min(f32):.3f}-{max(f32):.3f} times as fast side by side" in readme
    medium = re.search(r"rows of 50 and 64 ran ([\d.]+-[\d.]+) times as fast", page)[1]
    assert f"rows of 50 and 64 ran {medium} times as fast." in readme


def test_session_20_checksum_figures_match_the_recorded_run():
    text = (ROOT / "benches" / "results-hash-cost.txt").read_text()
    section = text.split("session 20 final code (e5e0529)")[1]
    mem = re.search(r"CPU on/off of the best times: median ([\d.]+), largest ([\d.]+)", section).groups()
    warm, cold = (re.search(rf"streaming {kind}, ckpt\+sum / ckpt: median ([\d.]+), largest [\d.]+; "
                            r"median of the paired ratios ([\d.]+)", section).groups() for kind in ("warm", "cold"))
    assert (f"in memory a median of {mem[0]} (largest {mem[1]}), from the page cache {warm[0]} (paired: {warm[1]}), "
            f"from the disk {cold[0]} (paired: {cold[1]})") in _page()
    assert 1.03 < float(mem[0]) < 1.06 and 1.03 < float(warm[0]) < 1.06 and float(cold[0]) < 1.01  # "about 4-5 %"
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert (f"Re-measured in session 20 on the final code (same kind of host), the medians were {mem[0]} in memory, "
            f"{warm[0]} from the page cache (paired: {warm[1]}) and {cold[0]} from the disk.") in readme


def test_session_20_final_floor_table_matches_the_recorded_runs():
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    page_text = (ROOT / "docs" / "performance.md").read_text()
    page = " ".join(page_text.split())
    assert _floor_summary(text, page_text, "20") in page
    after = text.split("\n=== session 20: after the final runs")[1].split("\n=== ")[0]
    rows = re.findall(r"floor\s+([\d.]+) ms \| old/floor [\d.]+ \(paired [\d.]+\) \| new/floor ([\d.]+) .*"
                      r"old/new paired ([\d.]+)", after)
    assert len(rows) == 3
    fl, nf, pr = ([float(r[i]) for r in rows] for i in range(3))
    assert (f"the final build read {min(nf):.2f}-{max(nf):.2f} of floors of {min(fl):.1f}-{max(fl):.1f} ms on float32 "
            f"rows of 5, 10 and 16 (typical, diagnostics), {min(pr):.3f}-{max(pr):.3f} times as fast") in page
