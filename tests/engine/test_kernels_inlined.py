"""The vector kernels' lane helpers (`Lanes::load512`, `inside512`, ... in
rust/src/simd/mod.rs, each a `#[target_feature]` wrapper of one or two
intrinsics) are inlined into every kernel of the built extension. A helper
left out of line is a call per vector: it made the AVX-512 long-row kernels
five times slower through `falsify` while the same code, built as the
`core_kernels` bench, inlined it (a closure does not take its caller's target
features). Not a timing test: it reads the extension's symbol table."""

import shutil
import subprocess

import edmf_rs._core as core


def test_no_lane_helper_is_left_out_of_line():
    nm = shutil.which("nm")
    assert nm, "nm (binutils, which the Rust build's linker needs) is on PATH"
    out = subprocess.run([nm, "-C", core.__file__], capture_output=True, text=True, check=True).stdout
    assert "edmf_core::kernel::" in out, "the extension keeps its symbol table"
    helpers = [line for line in out.splitlines() if "as edmf_core::simd::Lanes>::" in line]
    assert helpers == [], "lane helpers compiled out of line:\n" + "\n".join(helpers)
