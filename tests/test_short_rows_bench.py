"""The short-row benchmarks run on tiny arrays and print what they say: the
floor table of benches/throughput.py (--floor), benches/side_by_side.py,
benches/small_calls.py and benches/core_rate.py. Nothing here is timed."""

import importlib.util
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / "benches" / "throughput.py"


def run_script(name: str, argv: list[str]):
    """Runs benches/<name>.py's main(argv) (its helper modules sit beside it); returns the module."""
    script = SCRIPT.parent / f"{name}.py"
    sys.path.insert(0, str(script.parent))
    try:
        spec = importlib.util.spec_from_file_location(name, script)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        assert module.main(argv) == 0
    finally:
        sys.path.remove(str(script.parent))
    return module


def test_floor_table_prints_every_case(capsys):
    run_script("throughput", ["--floor", "--nm", "3", "12", "--mb", "0.05", "--repeat", "1"])
    rows = [line.split() for line in capsys.readouterr().out.splitlines() if line.strip()[:1].isdigit()]
    cases = {(r[0], r[1], r[2]) for r in rows}
    assert cases == {(n_m, d, c) for n_m in ("3", "12") for d in ("f64", "f32") for c in ("worst", "typical")}
    assert len(rows) == 3 * len(cases)  # floor, diagnostics, no diagnostics
    assert all(float(r[-4]) > 0 for r in rows)  # speed / floor


def test_side_by_side_prints_one_ratio_per_case(capsys):
    module = run_script("side_by_side", ["new", "--mb", "0.05", "--repeat", "1"])
    label, _, cells = capsys.readouterr().out.strip().partition(": ")
    assert label == "new"
    parsed = [cell.split() for cell in cells.split(" | ")]
    assert [tuple(c[:4]) for c in parsed] == [(str(n), d, c, m) for n, d, c, m in module.CASES]
    assert all(float(c[4]) > 0 for c in parsed)


def test_small_calls_prints_one_row_per_size(capsys):
    run_script("small_calls", ["--rows", "10", "7000", "--calls", "3"])
    rows = [line.split() for line in capsys.readouterr().out.splitlines() if line.strip()[:1].isdigit()]
    assert [r[0] for r in rows] == ["10", "7000"] and all(float(r[1]) > 0 for r in rows)


def test_core_rate_prints_both_passes_of_every_case_and_restores_the_threads(capsys):
    import edmf_rs
    before = edmf_rs.get_num_threads()
    run_script("core_rate", ["--nm", "3", "12", "--calls", "2", "--rounds", "1"])
    rows = [line.split() for line in capsys.readouterr().out.splitlines() if line.startswith("float")]
    assert {(r[0], r[1], r[2]) for r in rows} == {(d, n, c) for d in ("float64", "float32") for n in ("3", "12")
                                                  for c in ("worst", "typical")}
    assert len(rows) == 8 and all(float(r[3]) > 0 and float(r[4]) > 0 for r in rows)
    assert edmf_rs.get_num_threads() == before
