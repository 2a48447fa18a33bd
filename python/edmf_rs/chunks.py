"""Turns what users pass as ``predictions`` (an array, a ``.npy`` path or an
iterable of chunks) into checked 2-D chunks the Rust core reads in place."""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator

import numpy as np

from . import npy


def as_chunk(chunk, n_sensors: int, name: str = "predictions") -> np.ndarray:
    """A 2-D float32/float64 array with positive strides, aligned, n_sensors wide.

    Arrays already in that form are passed through without a copy.
    """
    arr = chunk if isinstance(chunk, np.ndarray) else np.asarray(chunk)
    if arr.dtype.kind not in "iufb" or arr.dtype.hasobject:
        raise TypeError(f"{name}: expected a numeric array of predictions, got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(
            f"{name}: expected a 2-D array of shape (instances, sensors), got {arr.ndim}-D shape {arr.shape}"
        )
    if arr.shape[1] != n_sensors:
        raise ValueError(
            f"{name}: expected {n_sensors} columns (one per sensor, as in measurements), "
            f"got shape {arr.shape}"
        )
    if arr.dtype not in (np.float32, np.float64) or not arr.dtype.isnative:
        arr = arr.astype(np.float64 if arr.dtype != np.float32 else np.float32)
    if any(s < 0 for s in arr.strides) or not arr.flags.aligned:
        arr = np.ascontiguousarray(arr)
    return arr


def iter_chunks(predictions, n_sensors: int, chunk_rows: int | None = None) -> Iterator[np.ndarray]:
    """Checked chunks in instance order; a file is read chunk by chunk."""
    if isinstance(predictions, (str, os.PathLike)):
        for block in npy.read_chunks(predictions, chunk_rows):
            yield as_chunk(block, n_sensors)
        return
    if _is_array_like(predictions):
        arr = as_chunk(predictions, n_sensors)
        step = chunk_rows or max(arr.shape[0], 1)
        for first in range(0, max(arr.shape[0], 1), step):
            yield arr[first:first + step]
        return
    if not isinstance(predictions, Iterable):
        raise TypeError(
            "predictions: expected a 2-D array, a path to a .npy file or an iterable of 2-D chunks, "
            f"got {type(predictions).__name__}"
        )
    width = None
    for k, chunk in enumerate(predictions):
        arr = np.asarray(chunk) if not isinstance(chunk, np.ndarray) else chunk
        if width is None and arr.ndim == 2:
            width = arr.shape[1]
        if arr.ndim == 2 and arr.shape[1] != width:
            raise ValueError(
                f"predictions: chunk {k} has {arr.shape[1]} columns, expected {width} like the first chunk"
            )
        yield as_chunk(arr, n_sensors, name=f"predictions (chunk {k})")


def _is_array_like(obj) -> bool:
    if isinstance(obj, np.ndarray) or hasattr(obj, "__array__"):
        return True
    # A list of rows is an array; a list of 2-D blocks is a sequence of chunks.
    if isinstance(obj, (list, tuple)):
        return len(obj) == 0 or np.ndim(obj[0]) < 2
    return False
