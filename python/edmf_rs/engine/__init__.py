"""The engine: the paper's method as functions on arrays.

Combined uncertainty (Eq. 4), threshold bounds (Eqs. 5-7), falsification of
model instances (Eq. 8) from arrays, files, iterables or a Python model, and
the result object. Everything public here is re-exported by ``edmf_rs``.
Depends on ``edmf_rs._core`` (Rust) and ``edmf_rs.stream`` (durable I/O).
"""
