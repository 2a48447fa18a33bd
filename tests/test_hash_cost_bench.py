"""The checksum-cost benchmark runs every case on a tiny size and prints one
row per case in every table (in memory, and streaming a file warm and cold,
with and without a checkpoint). Nothing here is timed: this only keeps the script from rotting."""

import importlib.util
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / "benches" / "hash_cost.py"


def test_every_case_is_printed(capsys):
    sys.path.insert(0, str(SCRIPT.parent))  # as when run as a script: its helper module sits beside it
    try:
        spec = importlib.util.spec_from_file_location("hash_cost", SCRIPT)
        bench = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(bench)
        assert bench.main(["--mbytes", "1", "--file-mbytes", "1", "--repeats", "1", "--cold-repeats", "1",
                           "--nm", "5", "10"]) == 0
    finally:
        sys.path.remove(str(SCRIPT.parent))
    out = capsys.readouterr().out
    in_memory, warm, cold = out.split("\nStreaming ")
    cases = [(dtype, nm, case, mode) for dtype in ("float64", "float32") for nm in ("5", "10")
             for case in ("worst", "typical") for mode in ("screen", "diagnostics")]
    rows = [line.split() for line in in_memory.splitlines() if line.startswith("float")]
    assert [(r[0], r[1], r[2], r[3]) for r in rows] == cases
    assert all(float(r[6]) > 0 for r in rows)  # CPU on/off
    for streaming, label in ((warm, "warm"), (cold, "cold")):
        assert streaming.startswith(f"1 MB per case from a .npy file ({label}")
        rows = [line.split() for line in streaming.splitlines() if line.startswith("float")]
        assert [(r[0], r[1], r[2], r[3]) for r in rows] == cases
        assert all(float(r[7]) > 0 and float(r[8]) > 0 for r in rows)  # checksum share, checkpoint / none
        assert f"streaming {label}, ckpt+sum / ckpt: median" in streaming
    assert "CPU: " in out and "load average" in out
