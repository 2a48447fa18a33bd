"""The throughput benchmark runs through every source (memory, file, a re-fed
block, the streaming file) on tiny sizes, and times methods that agree.

Nothing here is timed: this only keeps the script from rotting."""

import importlib.util
import sys
from pathlib import Path

import edmf_rs
import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parent.parent / "benches" / "throughput.py"


@pytest.fixture(scope="module")
def bench():
    sys.path.insert(0, str(SCRIPT.parent))  # as when run as a script: its helper module sits beside it
    try:
        spec = importlib.util.spec_from_file_location("throughput", SCRIPT)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(SCRIPT.parent))
    return module


def table_rows(text: str) -> list[list[str]]:
    return [line.split() for line in text.splitlines() if line.strip()[:1].isdigit()]


def test_every_source_and_method_is_timed(bench, tmp_path, capsys):
    threads = edmf_rs.get_num_threads()
    # 3,000 x 4 float64 = 96 KB in memory; 40,000 x 4 = 1.3 MB goes to a file;
    # 80,000 x 4 = 2.6 MB exceeds the file limit and re-feeds a 0.5 MB block.
    assert bench.main(["--n", "3000", "40000", "80000", "--nm", "4", "--repeat", "1", "--loop-n", "50",
                       "--mem-budget-gb", str(1e-3), "--max-file-gb", str(2e-3), "--refeed-gb", str(5e-4),
                       "--streaming-n", "5000", "--tmp", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert edmf_rs.get_num_threads() == threads
    rows = table_rows(out)
    sources = {(r[0], r[3]) for r in rows}
    assert {("3,000", "mem"), ("40,000", "file"), ("80,000", "iter"), ("5,000", "file")} <= sources
    for n, src in [("3,000", "mem"), ("40,000", "file"), ("80,000", "iter")]:
        methods = [" ".join(r[4:-5]) for r in rows if (r[0], r[3]) == (n, src)]
        assert any(m.startswith("numpy reference") for m in methods), methods
        assert sum(m.startswith("edmf_rs") for m in methods) == 2 * 4  # 1 and 2 threads, 2 modes, 2 cases
    assert "read floor is" in out and "peak RSS" in out
    assert not list(tmp_path.iterdir())  # temporary files removed


@pytest.mark.parametrize("case", ["worst", "typical"])
def test_the_timed_methods_agree(bench, case):
    p, y, t = bench.in_memory(20_000, 7, case, np.float64)
    expected = np.flatnonzero(bench.numpy_rule(p, y, t))
    if case == "worst":
        assert len(expected) == len(p)
    else:
        assert 0 < len(expected) < 0.1 * len(p)
    assert np.array_equal(bench.numpy_reference(p, y, t).candidate_indices, expected)
    assert np.array_equal(bench.numpy_reference_chunked(p, y, t).candidate_indices, expected)
    assert np.array_equal(np.concatenate(bench.numpy_chunked(p, y, t)), expected)
    assert np.array_equal(bench.python_loop(p[:500], y, t), expected[expected < 500])
    for diagnostics in (True, False):
        assert np.array_equal(bench.edmf(p, y, t, 2, diagnostics).candidate_indices, expected)
