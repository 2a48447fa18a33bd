"""Chunked reading of ``.npy`` files into one reused buffer, so falsifying a
file never holds more than a chunk of it in memory (numpy's own header reader
does the parsing)."""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np
from numpy.lib import format as npy_format

#: Bytes of predictions per chunk read from disk.
CHUNK_BYTES = 32 * 2**20


def read_header(fp, name: str = "predictions"):
    """(shape, fortran_order, dtype) of an open .npy file, positioned at the data."""
    try:
        version = npy_format.read_magic(fp)
        if version == (1, 0):
            return npy_format.read_array_header_1_0(fp)
        if version == (2, 0):
            return npy_format.read_array_header_2_0(fp)
        raise ValueError(f"unsupported .npy format version {version}")
    except ValueError as exc:
        raise ValueError(f"{name}: {getattr(fp, 'name', fp)} is not a readable .npy file ({exc})") from None


def open_npy(path, name: str = "predictions"):
    """Opens a 2-D numeric .npy file and checks it is complete.

    Returns (file object, shape, fortran_order, dtype, data offset).
    """
    try:
        fp = open(os.fspath(path), "rb")
    except OSError as exc:
        raise ValueError(f"{name}: cannot open {path!s}: {exc.strerror}") from None
    try:
        shape, fortran, dtype = read_header(fp, name)
        if dtype.kind not in "iuf" or dtype.hasobject:
            raise TypeError(f"{name}: expected a numeric .npy file, {path!s} holds dtype {dtype}")
        if len(shape) != 2:
            raise ValueError(f"{name}: expected a 2-D array (instances x sensors) in {path!s}, got shape {shape}")
        offset = fp.tell()
        expected = shape[0] * shape[1] * dtype.itemsize
        found = os.fstat(fp.fileno()).st_size - offset
        if found < expected:
            raise ValueError(
                f"{name}: {path!s} is truncated: its header promises {expected} bytes of data, found {found}"
            )
        return fp, shape, fortran, dtype, offset
    except BaseException:
        fp.close()
        raise


def read_chunks(path, chunk_rows: int | None = None, name: str = "predictions") -> Iterator[np.ndarray]:
    """Yields consecutive row blocks of a .npy file.

    The yielded array is a reused buffer: use it before asking for the next one.
    """
    fp, (n, n_m), fortran, dtype, offset = open_npy(path, name)
    with fp:
        rows = chunk_rows or max(1024, CHUNK_BYTES // max(1, n_m * dtype.itemsize))
        buf = np.empty((min(rows, n), n_m), dtype=dtype, order="F" if fortran else "C")
        for first in range(0, n, rows):
            count = min(rows, n - first)
            block = buf[:count]
            if fortran:
                for j in range(n_m):  # each column of a Fortran file is contiguous
                    fp.seek(offset + (j * n + first) * dtype.itemsize)
                    _fill(fp, block[:, j], path, name)
            else:
                _fill(fp, block, path, name)
            yield block


def _fill(fp, out: np.ndarray, path, name: str) -> None:
    view = memoryview(out).cast("B")
    got = fp.readinto(view)
    if got != view.nbytes:
        raise ValueError(f"{name}: {path!s} ended early (it was truncated while being read)")
