"""The README's Python examples run as written, and its two commands are the
ones CI runs."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parent.parent / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_readme_has_examples():
    assert len(python_blocks()) >= 2


@pytest.mark.parametrize("index", range(len(python_blocks())))
def test_readme_example_runs_on_its_own(index, tmp_path, monkeypatch):
    """Each block runs alone, in a fresh namespace and folder, as a reader would paste it."""
    monkeypatch.chdir(tmp_path)
    block = python_blocks()[index]
    exec(compile(block, f"{README} (python block {index + 1})", "exec"), {"__name__": "__readme__"})


def test_the_dask_block_says_how_to_install_the_extra():
    dask_blocks = [b for b in python_blocks() if "edmf_rs.dask" in b]
    assert dask_blocks and all('pip install ".[dask]"' in b for b in dask_blocks)


def test_ci_runs_the_readme_test_command():
    text = README.read_text(encoding="utf-8")
    ci = (README.parent / ".ci" / "run").read_text(encoding="utf-8")
    command = ci.strip().splitlines()[-1]
    assert command in text, "the README must show the exact command .ci/run runs"


def test_the_adaptive_numbers_are_the_benchmarks():
    """The README's adaptive-sampling claim is the girder line of benches/results-adaptive.txt."""
    results = (README.parent / "benches" / "results-adaptive.txt").read_text(encoding="utf-8")
    girder = results.split("girder, 3 parameters:")[1].split("girder, 5 parameters:")[0]
    runs = re.search(r"adaptive: ([\d,]+) runs in", girder).group(1)
    dense = re.search(r"dense Sobol' needs ([\d,]+) runs for the 2 % target", girder).group(1)
    assert "meets the 2 % target" in girder
    text = " ".join(README.read_text(encoding="utf-8").split())
    assert (f"within 2 % of the domain and the prognosis interval within 2 % of its width with {runs} runs, where "
            f"dense Sobol' sampling needed {dense}") in text
    five = results.split("girder, 5 parameters:")[1]
    m = re.search(r"adaptive: ([\d,]+) runs .*?ranges off by ([\d.]+) % of the domain, prognosis off by ([\d.]+) %", five)
    assert "meets the 2 % target" in five and "no dense run up to 2^19 met the 2 % target" in five
    assert (f"on its 5-parameter variant {m[1]} runs came within {m[2]} % of the domain on every parameter's range "
            f"and {float(m[3]):.1f} % on the prognosis, where no dense run up to 2^19 met the target") in text


def test_the_performance_summary_is_the_benchmark_file():
    """The README's 2,000,000 x 50 ranges are the min and max over the 2-thread rows of benches/results-2m50.txt."""
    rows = [line.split() for line in (README.parent / "benches" / "results-2m50.txt").read_text().splitlines()
            if "edmf_rs 2 thr" in line and "2,000,000   50" in line]
    assert len(rows) == 12
    ms = [round(float(r[-5]) * 1000) for r in rows]
    numpy_x = [int(float(r[-2])) for r in rows]
    rule_x = [int(float(r[-1])) for r in rows]
    text = " ".join(README.read_text(encoding="utf-8").split())
    assert (f"takes {min(ms)}-{max(ms)} ms on 2 threads: {min(numpy_x)}-{max(numpy_x)}× the plain NumPy reference"
            in text)
    assert f"and {min(rule_x)}-{max(rule_x)}× the leanest NumPy rule" in text


def test_the_memory_numbers_are_the_benchmark_file():
    """The README's bounded-memory claim is the largest row of benches/results-memory.txt."""
    rows = [line.split() for line in (README.parent / "benches" / "results-memory.txt").read_text().splitlines()
            if re.match(r"\s+[\d,]+\s+[\d,]+\s+[\d.]+\s", line)]
    largest = max(rows, key=lambda r: int(r[0].replace(",", "")))
    n, candidates, peak = int(largest[0].replace(",", "")), int(largest[1].replace(",", "")), float(largest[2])
    assert n == 2**23
    text = " ".join(README.read_text(encoding="utf-8").split())
    assert (f"the cantilever with 2^23 Sobol' instances and {candidates / 1e6:.1f} million candidates peaks at "
            f"{peak:.0f} MB") in text


def test_the_checksum_cost_is_the_benchmark_file():
    """The README's checksum costs are the medians printed by the last run in benches/results-hash-cost.txt."""
    last = (README.parent / "benches" / "results-hash-cost.txt").read_text().split("\n=== ")[-1]
    in_memory = re.search(r"CPU on/off of the best times: median ([\d.]+)", last)[1]
    warm = re.search(r"streaming warm, ckpt\+sum / ckpt: median ([\d.]+)", last)[1]
    cold = re.search(r"streaming cold, ckpt\+sum / ckpt: median ([\d.]+)", last)[1]
    readme = " ".join(README.read_text(encoding="utf-8").split())
    assert f"a median {in_memory} times the CPU time of the falsifier alone" in readme
    tables = last.split("\nStreaming ")[1:]
    assert [t.split("(")[1].split(")")[0] for t in tables] == ["warm", "cold: read from the disk"]
    shares, rates = [], []
    for table in tables:
        rows = [line.split() for line in table.splitlines() if line.startswith("float")]
        assert len(rows) == 24
        shares.append([float(r[7]) for r in rows])
        rates.append([float(r[9]) for r in rows])
    assert (f"a median {warm} times as long as with the checksum replaced by a row counter when the file is in "
            f"the page cache ({min(rates[0]):.0f}-{max(rates[0]):.0f} GB/s without a checkpoint; a noisy "
            f"wall-clock figure: single cases range from {min(shares[0]):.2f} to {max(shares[0]):.2f}), and a "
            f"median {cold} (single cases {min(shares[1]):.2f} to {max(shares[1]):.2f}) when it is read from the "
            f"disk ({min(rates[1]):.1f}-{max(rates[1]):.1f} GB/s") in readme
    sections = (README.parent / "benches" / "results-hash-cost.txt").read_text().split("\n=== ")
    busier = next(s for s in sections if s.startswith("2026-11-24 07:31 UTC, fletcher64x8/2"))
    busier = re.search(r"streaming, ckpt\+sum / ckpt: median ([\d.]+)", busier)[1]
    session_13 = next(s for s in sections if s.startswith("2026-11-24 20:47 UTC, session 13, run 2"))
    session_13 = re.search(r"streaming warm, ckpt\+sum / ckpt: median ([\d.]+)", session_13)[1]
    assert (f"session 13 measured {session_13} there, before the falsifier itself got faster (session 15), and "
            f"on a busier host with the same checksum {busier}.") in readme
    beside = next(s for s in sections if s.startswith("2026-11-25 04:30 UTC, session 17: the session start's code"))
    beside = re.search(r"streaming warm, ckpt\+sum / ckpt: median ([\d.]+)", beside)[1]
    assert f"the code before the kernel summed gave {beside} in a run beside it" in readme


def test_the_checksum_rates_are_the_benchmark_file():
    """The README's checksum, XXH3 and screening rates are the medians of the last runs in
    benches/results-checksum.txt (L1 and L2)."""
    text = (README.parent / "benches" / "results-checksum.txt").read_text()
    medians = dict(re.findall(r"checksum/(\S+)\s+(?:time:.*\n)?\s+thrpt:\s+\[\S+ GiB/s ([\d.]+) GiB/s", text))
    sums = [float(medians[f"{dtype}/{isa}/{kib}"]) for dtype in ("sum", "sum32") for isa in ("Avx2", "Avx512")
            for kib in (16, 256)]
    xxh3 = [float(medians[f"xxh3_128/{kib}"]) for kib in (16, 256)]
    screen = [float(medians[f"screen/worst/{kib}"]) for kib in (16, 256)]
    readme = " ".join(README.read_text(encoding="utf-8").split())
    assert (f"sums {min(sums):.0f}-{max(sums):.0f} GiB/s per core from L1 and L2, float64 or float32, where "
            f"XXH3-128 hashes {min(xxh3):.0f}-{max(xxh3):.0f} GiB/s and the screening kernel reads "
            f"{min(screen):.1f}-{max(screen):.1f} GiB/s on the same bytes") in readme
