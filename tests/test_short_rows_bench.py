"""The floor table of benches/throughput.py (--floor) runs on a tiny array and
prints one floor row and both edmf_rs rows per case. Nothing here is timed."""

import importlib.util
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / "benches" / "throughput.py"


def test_floor_table_prints_every_case(capsys):
    sys.path.insert(0, str(SCRIPT.parent))  # its helper modules sit beside it
    try:
        spec = importlib.util.spec_from_file_location("throughput", SCRIPT)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        assert module.main(["--floor", "--nm", "3", "12", "--mb", "0.05", "--repeat", "1"]) == 0
    finally:
        sys.path.remove(str(SCRIPT.parent))
    rows = [line.split() for line in capsys.readouterr().out.splitlines() if line.strip()[:1].isdigit()]
    cases = {(r[0], r[1], r[2]) for r in rows}
    assert cases == {(n_m, d, c) for n_m in ("3", "12") for d in ("f64", "f32") for c in ("worst", "typical")}
    assert len(rows) == 3 * len(cases)  # floor, diagnostics, no diagnostics
    assert all(float(r[-4]) > 0 for r in rows)  # speed / floor


def test_side_by_side_prints_one_ratio_per_case(capsys):
    script = SCRIPT.parent / "side_by_side.py"
    sys.path.insert(0, str(script.parent))
    try:
        spec = importlib.util.spec_from_file_location("side_by_side", script)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        assert module.main(["new", "--mb", "0.05", "--repeat", "1"]) == 0
    finally:
        sys.path.remove(str(script.parent))
    label, _, cells = capsys.readouterr().out.strip().partition(": ")
    assert label == "new"
    parsed = [cell.split() for cell in cells.split(" | ")]
    assert [tuple(c[:4]) for c in parsed] == [(str(n), d, c, m) for n, d, c, m in module.CASES]
    assert all(float(c[4]) > 0 for c in parsed)
