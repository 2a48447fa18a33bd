"""Session 24's floor tables in docs/performance.md ("AMD EPYC of CPU family 25
(session 24)"), recomputed from the runs recorded in benches/results-short-rows.txt."""

from pathlib import Path

from test_performance_tables import _floor_summary, _level_tables, _target

ROOT = Path(__file__).resolve().parent.parent


def test_the_session_24_floor_table_matches_the_recorded_runs():
    text = (ROOT / "benches" / "results-short-rows.txt").read_text()
    page_text = (ROOT / "docs" / "performance.md").read_text()
    page = " ".join(page_text.split())
    assert _floor_summary(text, page_text, "24") + "." in page
    *_, medians = _level_tables(text, page_text, "24")
    short = {k: round(_target(k[1], k[3], k[4]) - m, 2) for k, m in medians.items() if m < _target(k[1], k[3], k[4])}
    worst = max(short, key=short.get)
    assert worst == ("avx512", "16", "f64", "typical", "diagnostics")
    rest = [v for k, v in short.items() if k != worst]
    assert all(k[3] == "typical" for k in short if k[4] == "diagnostics")
    assert (f"by {min(rest):.2f}-{max(rest):.2f} of the floor except float64 rows of 16 at AVX-512 with diagnostics "
            f"({medians[worst]:.2f},") in page
