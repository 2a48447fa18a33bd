"""tests/engine/test_short_rows.py and the property tests of
tests/engine/test_falsify_vs_reference.py again with the kernels capped at each
instruction-set level (``EDMF_RS_ISA``, read once per process, hence a
subprocess per level). A level this CPU lacks falls back to the fastest it has."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent


@pytest.mark.parametrize("isa", ["portable", "avx2", "avx512"])
def test_every_level_matches_the_reference(isa):
    env = dict(os.environ, EDMF_RS_ISA=isa, EDMF_RS_EXAMPLES="60")
    files = [str(HERE / "test_short_rows.py"), str(HERE / "test_falsify_vs_reference.py")]
    run = subprocess.run([sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *files],
                         env=env, capture_output=True, text=True, cwd=HERE.parents[1])
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert " passed" in run.stdout
