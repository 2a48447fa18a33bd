"""The checksum-cost benchmark runs every case on a tiny size and prints one
row per case. Nothing here is timed: this only keeps the script from rotting."""

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / "benches" / "hash_cost.py"


def test_every_case_is_printed(capsys):
    spec = importlib.util.spec_from_file_location("hash_cost", SCRIPT)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    assert bench.main(["--mbytes", "1", "--repeats", "1", "--nm", "5", "10"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith("float")]
    assert [(r[0], r[1], r[2], r[3]) for r in rows] == [
        (dtype, nm, case, mode) for dtype in ("float64", "float32") for nm in ("5", "10")
        for case in ("worst", "typical") for mode in ("screen", "diagnostics")]
    assert all(float(r[6]) > 0 for r in rows)  # CPU on/off
    assert "CPU: " in out and "load average" in out
