"""The vector kernels' prefetch (``rust/src/simd/prefetch.rs``): chosen per
CPU, named by ``EDMF_RS_PREFETCH`` or set at run time to compare; a hint
that never changes a candidate."""

import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import edmf_rs
from edmf_rs import _core, reference

NAMES = ["t0:0", "t1:8192", "t2:64", "nta:4096", "nta:65536", "off"]


@pytest.fixture
def restore_prefetch():
    own = _core.prefetch()
    yield
    _core.set_prefetch(own)


def test_this_cpus_prefetch_is_named_and_settable(restore_prefetch):
    assert _core.prefetch() in ("t1:8192", "nta:4096", "off")  # "off" where not x86-64
    for name in ("t1:8192", "nta:4096"):
        _core.set_prefetch(name)
        assert _core.prefetch() == name
    for bad in ("", "nta", "nta:100", "l2:4096", "t1:-64", "t1:2097152"):
        with pytest.raises(ValueError, match="name: expected 't0', 't1', 't2' or 'nta'"):
            _core.set_prefetch(bad)


def run_python(code: str, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], env={**os.environ, **env}, capture_output=True,
                          text=True, timeout=120)


def test_the_environment_names_the_prefetch():
    code = "from edmf_rs import _core; print(_core.prefetch())"
    assert run_python(code, env={"EDMF_RS_PREFETCH": "t2:128"}).stdout.strip() == "t2:128"
    # A name the core cannot read leaves this CPU's choice.
    own = run_python(code, env={"EDMF_RS_PREFETCH": ""}).stdout.strip()
    assert run_python(code, env={"EDMF_RS_PREFETCH": "fast"}).stdout.strip() == own


@settings(max_examples=25, deadline=None)
@given(n_m=st.sampled_from([1, 5, 10, 16, 50, 200]), n=st.integers(1, 3000), seed=st.integers(0, 2**32 - 1),
       dtype=st.sampled_from([np.float64, np.float32]), diagnostics=st.booleans())
def test_candidates_do_not_depend_on_the_prefetch(n_m, n, seed, dtype, diagnostics):
    rng = np.random.default_rng(seed)
    p = rng.uniform(-1.2, 1.2, (n, n_m)).astype(dtype)
    y = np.zeros(n_m)
    t = edmf_rs.Thresholds(-np.ones(n_m), np.ones(n_m))
    expected = reference.falsify(p, y, t)
    own = _core.prefetch()
    try:
        for name in NAMES:
            _core.set_prefetch(name)
            r = edmf_rs.falsify(p, y, t, diagnostics=diagnostics, progress=False)
            np.testing.assert_array_equal(r.candidate_indices, expected.candidate_indices)
            if diagnostics:
                np.testing.assert_array_equal(r.per_sensor_falsified, expected.per_sensor_falsified)
    finally:
        _core.set_prefetch(own)
