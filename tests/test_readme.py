"""The README's Python examples run as written, and its two commands are the
ones CI runs."""

import re
from collections import defaultdict
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


def _hash_cost_section(title: str) -> str:
    """The one section of benches/results-hash-cost.txt whose title holds `title`."""
    sections = (README.parent / "benches" / "results-hash-cost.txt").read_text().split("\n=== ")
    found = [s for s in sections if title in s.split("\n")[0]]
    assert len(found) == 1, title
    return found[0]


def test_the_checksum_cost_is_the_benchmark_file():
    """The README's checksum costs are the medians printed by the session's runs in
    benches/results-hash-cost.txt: the final code at AVX-512 and AVX2, the session start's, and the
    side-by-side runs at AVX2."""
    final = _hash_cost_section("session 18, final code, AVX-512")
    avx2 = _hash_cost_section("session 18, final code, AVX2")
    before = _hash_cost_section("session 18: the session start's code, AVX-512")
    side = _hash_cost_section("session 18: the session start's code, AVX2 in memory")

    def in_memory(section):
        return re.search(r"CPU on/off of the best times: median ([\d.]+)", section)[1]

    def warm(section):
        return re.search(r"streaming warm, ckpt\+sum / ckpt: median ([\d.]+), largest [\d.]+; median of the "
                         r"paired ratios ([\d.]+)", section)

    runs = side.split("\n== ")[1:]
    spans = {}
    for label in ("venv", "venv_new"):
        medians = sorted(float(in_memory(r)) for r in runs if r.startswith(f"{label},"))
        assert len(medians) == 2, label
        spans[label] = f"{medians[0]:.3f}-{medians[-1]:.3f}"
    cold = re.search(r"streaming cold, ckpt\+sum / ckpt: median ([\d.]+)", final)[1]
    tables = final.split("\nStreaming ")[1:]
    assert [t.split("(")[1].split(")")[0] for t in tables] == ["warm", "cold: read from the disk"]
    shares, rates = [], []
    for table in tables:
        rows = [line.split() for line in table.splitlines() if line.startswith("float")]
        assert len(rows) == 32
        shares.append([float(r[7]) for r in rows])
        rates.append([float(r[9]) for r in rows])
    before_warm = re.search(r"streaming warm, ckpt\+sum / ckpt: median ([\d.]+)", before)[1]
    readme = " ".join(README.read_text(encoding="utf-8").split())
    assert (f"takes a median {in_memory(final)} times the CPU time of the falsifier alone (the session start's "
            f"code: {in_memory(before)}); with the kernels capped at AVX2, {in_memory(avx2)} on 96 MB a case, and "
            f"side by side on 384 MB a case {spans['venv_new']} against the session start's {spans['venv']}.") in readme
    assert (f"the run takes a median {warm(final)[1]} times as long as with the checksum replaced by a row counter "
            f"when the file is in the page cache ({min(rates[0]):.0f}-{max(rates[0]):.0f} GB/s without a checkpoint; "
            f"a noisy wall-clock figure: single cases range from {min(shares[0]):.2f} to {max(shares[0]):.2f}, and "
            f"the median of each case's ratios within a round is {warm(final)[2]}), and a median {cold} (single "
            f"cases {min(shares[1]):.2f} to {max(shares[1]):.2f}) when it is read from the disk "
            f"({min(rates[1]):.1f}-{max(rates[1]):.1f} GB/s") in readme
    assert f"At AVX2 the page-cache figures are {warm(avx2)[1]} and {warm(avx2)[2]}." in readme
    assert f"(the session start's code gave {before_warm} there)" in readme


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


def test_the_performance_page_checksum_figures_are_the_benchmark_file():
    """docs/performance.md's table and sentences on the checksum in the kernels' pass are the session-18 runs."""
    final = _hash_cost_section("session 18, final code, AVX-512")
    run_1 = _hash_cost_section("session 18, final kernels, AVX-512, run 1")
    avx2 = _hash_cost_section("session 18, final code, AVX2")
    before = _hash_cost_section("session 18: the session start's code, AVX-512")
    side = _hash_cost_section("session 18: the session start's code, AVX2 in memory")

    def median(section, what):
        return re.search(rf"{what}: median ([\d.]+)", section)[1]

    def paired(section):  # the in-memory table's paired medians by case
        table = section.split("\nStreaming ")[0]
        return {" ".join(f[:4]): float(f[7]) for f in (line.split() for line in table.splitlines())
                if f and f[0].startswith("float")}

    def span(values):
        return f"{min(values):.2f}-{max(values):.2f}"

    mem, warm, cold = "CPU on/off of the best times", r"streaming warm, ckpt\+sum / ckpt", r"streaming cold, ckpt\+sum / ckpt"
    rows50 = {s: {d: span([v for k, v in paired(s).items() if k.startswith(f"{d} 50 ")])
                  for d in ("float64", "float32")} for s in (before, final)}
    page = " ".join((README.parent / "docs" / "performance.md").read_text().split())
    warm_paired = re.search(r"streaming warm, .*median of the paired ratios ([\d.]+)", final)[1]
    assert (f"| in memory, CPU on/off of the best times, median of the cases | {median(before, mem)} (n_m 5, 10, 50) | "
            f"{median(final, mem)} (an earlier run of the same kernels: {median(run_1, mem)}) |") in page
    assert (f"| in memory, rows of 50 sensors, paired medians | {rows50[before]['float64']} (float64), "
            f"{rows50[before]['float32']} (float32) | {rows50[final]['float64']} (float64), "
            f"{rows50[final]['float32']} (float32) |") in page
    assert (f"| streaming from the page cache, median of the cases (best times) | {median(before, warm)} | "
            f"{median(final, warm)} (earlier run: {median(run_1, warm)}) |") in page
    assert f"| streaming from the page cache, median of the paired ratios | | {warm_paired} |" in page
    assert f"| streaming from the disk, median of the cases | | {median(final, cold)} (earlier run: {median(run_1, cold)}) |" in page
    assert f"paired medians of the final run range from {span(paired(final).values()).replace('-', ' to ')}," in page
    runs = side.split("\n== ")[1:]
    side_medians = {label: sorted(float(median(r, mem)) for r in runs if r.startswith(f"{label},"))
                    for label in ("venv", "venv_new")}
    assert (f"the median over the cases went from {side_medians['venv'][0]:.3f}-{side_medians['venv'][-1]:.3f} to "
            f"{side_medians['venv_new'][0]:.3f}-{side_medians['venv_new'][-1]:.3f}") in page
    by_case = {label: defaultdict(list) for label in side_medians}
    for r in runs:
        label = r.split(",")[0]
        for case, value in paired(r).items():
            by_case[label][case].append(value)
    periodic = [c for c in by_case["venv"] if c.split()[1] in ("5", "10", "16") and c.endswith("typical diagnostics")]
    wide = ["float32 50 typical diagnostics"]
    others = [c for c in by_case["venv"] if c not in periodic + wide]

    def spread(label, cases):
        return span([v for c in cases for v in by_case[label][c]])

    assert (f"The paired medians of the other cases went from {spread('venv', others)} to "
            f"{spread('venv_new', others)},") in page
    assert (f"(rows of 5, 10 and 16) stay at {spread('venv_new', periodic)} (before: {spread('venv', periodic)}), as "
            f"do float32 rows of 50 with diagnostics, most falsified ({spread('venv_new', wide)}; before "
            f"{spread('venv', wide)})") in page
    avx2_warm = re.search(r"streaming warm, ckpt\+sum / ckpt: median ([\d.]+), .*paired ratios ([\d.]+)", avx2)
    assert (f"gave {median(avx2, mem)} in memory, higher than at 384 MB for reasons not measured, {avx2_warm[1]} from "
            f"the page cache (paired: {avx2_warm[2]}) and {median(avx2, cold)} from the disk") in page
