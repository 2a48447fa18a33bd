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
