"""Session 21's figures in docs/performance.md ("AMD EPYC of CPU family 25
(session 21)"): the periodic kernel's cost by part, the split string alone
and through falsify, recomputed from the runs recorded in
benches/results-short-rows.txt."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LEVELS = {"Avx512": "AVX-512", "Avx2": "AVX2"}


def _page() -> str:
    """The page with its line breaks as spaces (table rows keep their own lines)."""
    return re.sub(r"(?<!\|)\n(?!\|)", " ", (ROOT / "docs" / "performance.md").read_text())


def _section(title: str) -> str:
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    parts = [s for s in text.split("\n=== ") if s.startswith(title)]
    assert len(parts) == 1, title
    return parts[0]


def _medians(title: str) -> dict[tuple[str, ...], list[int]]:
    """Per benchmark (rows, case, dtype, level), the medians of each build."""
    lines = _section(title).splitlines()
    header = next(line.split() for line in lines if line.startswith("bench "))
    builds = len(header) - 1 - (header[-2:] == ["every", "round"]) * 2
    found = {}
    for line in lines:
        cells = line.split()
        m = re.match(r"short_rows_(\d+)/(\w+)/diagnose_bits/(f\d\d)/(\w+)$", cells[0] if cells else "")
        if m:
            found[m.groups()] = [int(v) for v in cells[1:1 + builds]]
    return found


def test_the_breakdown_table_is_the_recorded_run():
    runs = _medians("session 21: where the diagnostics' time goes")
    assert len(runs) == 6
    page = _page()
    for rows in ("5", "10", "16"):
        for level, name in LEVELS.items():
            whole, nonan, noonly, noout = runs[(rows, "typical", "f32", level)]
            assert f"| rows of {rows}, {name} | {whole} | {nonan} | {noonly} | {noout} |" in page
            if rows != "16":
                # "Falsified only by" is the largest part where the periodic kernel runs.
                assert noonly > max(nonan, noout) > 0.9 * whole


def test_the_split_string_alone_is_the_recorded_run():
    runs = _medians("session 21: the split string, the kernel alone")
    assert len(runs) == 16
    page = _page()
    for rows in ("5", "10"):
        for case in ("typical", "worst"):
            cells = [f"{runs[(rows, case, 'f32', lv)][0]} -> {runs[(rows, case, 'f32', lv)][1]}" for lv in LEVELS]
            assert f"| float32 rows of {rows}, {case} | {cells[0]} | {cells[1]} |" in page
        # The typical rows gained at both levels.
        assert all(runs[(rows, "typical", "f32", lv)][1] > runs[(rows, "typical", "f32", lv)][0] for lv in LEVELS)
    controls = []
    for lv in LEVELS:
        ratios = [new / old for k, (old, new) in runs.items() if k[2] == "f64" and k[3] == lv]
        controls.append(f"{min(ratios):.2f}-{max(ratios):.2f}")
    assert f"| float64 controls (unchanged kernel), new / old | {controls[0]} | {controls[1]} |" in page
    worst = runs[("5", "worst", "f32", "Avx2")][1] * 5 * 4 / 1000
    assert f"at {worst:.1f} GB/s a core it is still above the 30 GB/s a core" in page
    assert worst > 30


def test_the_split_string_through_falsify_is_the_recorded_run():
    section = _section("session 21: the split string through falsify")
    # The two 41-round runs (AVX-512, then AVX2) follow the 15-round one.
    assert section.count("median over 12 cases") == 1 and section.count("median over 4 cases") == 2
    short_run, long_runs = section.split("median over 12 cases")
    summary = re.search(r"^: (\d\.\d{3}) \(range (\d\.\d{3})-(\d\.\d{3})\)$", long_runs, re.M)
    ratios = re.findall(r"^\s+(5|10) f32\s+(worst|typical) diag .* old/new paired (\d\.\d{3})$", long_runs, re.M)
    assert len(ratios) == 8
    spans = {}
    for case in ("typical", "worst"):
        values = sorted(float(r) for _, c, r in ratios if c == case)
        spans[case] = f"{values[0]:.3f}-{values[-1]:.3f}"
    page = _page()
    assert (f"the split string ran {spans['typical']} times as fast on typical rows of 5 and 10 and "
            f"{spans['worst']} on the worst case, at both levels") in page
    assert (f"a first run of 15 rounds, with controls, gave a median of {summary[1]} over 12 cases "
            f"({summary[2]}-{summary[3]})") in page


def test_the_nan_experiment_not_kept_is_the_recorded_run():
    # Its two runs are headed "=== run N ===", which `_section` would cut at.
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    section = text.split("=== session 21: NaN looked for once per flush, not kept")[1].split("\n=== session")[0]
    spans = []
    for run in re.split(r"^=== run \d ===$", section, flags=re.M)[1:]:
        paired = [float(line.split()[3]) for line in run.splitlines() if line.startswith("short_rows_")]
        assert len(paired) == 16
        spans.append(f"{min(paired):.3f}-{max(paired):.3f}")
    page = _page()
    assert (f"ran {spans[0]} and, with each period summed apart first, {spans[1]} times as fast alone "
            "(the paired medians of 16 cases") in page
