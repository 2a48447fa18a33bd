"""Turns what users pass as ``predictions`` (an array, a ``.npy`` path or an
iterable of chunks) into checked 2-D chunks the Rust core reads in place,
optionally from a given instance on (to resume a run)."""

from __future__ import annotations

import abc
import os
from collections.abc import Callable, Iterable, Iterator

import numpy as np

from . import npy

#: Called with (first instance, rows) for every block of rows a resumed run
#: skips, in instance order from instance 0, so it can check all of them.
Skipped = Callable[[int, np.ndarray], None]


def digestible(rows) -> np.ndarray:
    """``rows`` as a 2-D float32/float64 array the Rust digest reads in place."""
    arr = np.asarray(rows)
    arr = arr[:, None] if arr.ndim == 1 else arr
    if (arr.dtype not in (np.float32, np.float64) or not arr.dtype.isnative or not arr.flags.aligned
            or any(s < 0 for s in arr.strides)):
        # a copy, always: ascontiguousarray returns an empty array with negative strides unchanged
        arr = np.array(arr, dtype=np.float32 if single(arr.dtype) else np.float64, order="C")
    return arr


def checked_array(chunk, n_sensors: int, name: str = "predictions") -> np.ndarray:
    """``chunk`` as an array whose dtype is numeric and whose shape is
    (instances, n_sensors); nothing is converted or copied."""
    try:
        arr = chunk if isinstance(chunk, np.ndarray) else np.asarray(chunk)
    except (TypeError, ValueError) as exc:  # e.g. ragged nested lists
        raise TypeError(f"{name}: expected a 2-D array of numbers ({exc})") from None
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
    return arr


def single(dtype: np.dtype) -> bool:
    """Whether values of ``dtype`` are handed to Rust as float32 (float32 of
    either byte order; everything else goes as float64). The checkpoint's
    block checksum sums the values at that width."""
    return dtype.kind == "f" and dtype.itemsize == 4


def as_chunk(chunk, n_sensors: int, name: str = "predictions") -> np.ndarray:
    """A 2-D float32/float64 array with positive strides, aligned, n_sensors wide.

    Arrays already in that form are passed through without a copy.
    """
    arr = checked_array(chunk, n_sensors, name)
    if arr.dtype not in (np.float32, np.float64) or not arr.dtype.isnative:
        arr = arr.astype(np.float32 if single(arr.dtype) else np.float64)
    if any(s < 0 for s in arr.strides) or not arr.flags.aligned:
        arr = arr.copy(order="C")  # (ascontiguousarray keeps a contiguous misaligned array as is)
    return arr


class Source(abc.ABC):
    """Where predictions come from; ``n_instances`` is None when unknown."""

    n_instances: int | None = None
    #: False for an iterator (a generator, a file object...): it cannot be read twice.
    rereadable: bool = True

    @abc.abstractmethod
    def chunks(self, start: int = 0, skipped: Skipped | None = None) -> Iterator[np.ndarray]:
        """Checked chunks in instance order from instance ``start`` on. When
        resuming, ``skipped`` is given every row before ``start``, in blocks."""


class ArraySource(Source):
    """An in-memory or memory-mapped array. Arrays the core reads in place are
    passed whole; others (integers, other byte orders, a ``np.memmap``) are
    converted chunk by chunk, so memory does not grow with N."""

    def __init__(self, arr, n_sensors: int, chunk_rows: int | None):
        arr = checked_array(arr, n_sensors)  # nothing converted yet
        self.arr, self.n_sensors = arr, n_sensors
        self.n_instances = int(arr.shape[0])
        # A converted chunk is a new array (no base); a chunk read in place is a view of `arr`.
        converted = as_chunk(arr[:1], n_sensors).base is None
        if chunk_rows is None and (isinstance(arr, np.memmap) or converted):
            chunk_rows = max(1024, npy.CHUNK_BYTES // max(1, n_sensors * arr.dtype.itemsize))
        self.chunk_rows = chunk_rows

    def chunks(self, start=0, skipped=None):
        arr = self.arr
        if skipped is not None:
            block = self.chunk_rows or max(1024, npy.CHUNK_BYTES // max(1, 8 * self.n_sensors))
            for first in range(0, min(start, arr.shape[0]), block):
                skipped(first, as_chunk(arr[first:min(first + block, start)], self.n_sensors))
        step = self.chunk_rows or max(arr.shape[0] - start, 1)
        if start == 0 and arr.shape[0] == 0:
            yield as_chunk(arr, self.n_sensors)  # an empty run still meets the core once (it checks the width)
        for first in range(start, arr.shape[0], step):
            yield as_chunk(arr[first:first + step], self.n_sensors)


class FileSource(Source):
    def __init__(self, path, n_sensors: int, chunk_rows: int | None):
        with npy.NpyFile(path) as f:
            if f.n_cols != n_sensors:
                raise ValueError(
                    f"predictions: {path!s} has {f.n_cols} columns (shape {f.shape}), expected {n_sensors} "
                    "(one per sensor, as in measurements)"
                )
            self.n_instances = f.n_rows
        self.path, self.chunk_rows = path, chunk_rows

    def chunks(self, start=0, skipped=None):
        if skipped is not None and start > 0:
            first = 0
            for block in npy.read_chunks(self.path, self.chunk_rows, stop=start):
                skipped(first, block)
                first += block.shape[0]
        yield from npy.read_chunks(self.path, self.chunk_rows, start=start)


class IterableSource(Source):
    def __init__(self, chunks: Iterable, n_sensors: int):
        self.iterable, self.n_sensors = chunks, n_sensors
        self.rereadable = not isinstance(chunks, Iterator)

    def chunks(self, start=0, skipped=None):
        return skip_rows(self._checked(), start, skipped, "predictions")

    def _checked(self) -> Iterator[np.ndarray]:
        width = None
        for k, chunk in enumerate(self.iterable):
            name = f"predictions (chunk {k})"
            try:
                arr = chunk if isinstance(chunk, np.ndarray) else np.asarray(chunk)
            except (TypeError, ValueError) as exc:  # e.g. ragged nested lists
                raise TypeError(f"{name}: expected a 2-D array of numbers ({exc})") from None
            if width is None and arr.ndim == 2:
                width = arr.shape[1]
            if arr.ndim == 2 and arr.shape[1] != width:
                raise ValueError(
                    f"predictions: chunk {k} has {arr.shape[1]} columns, expected {width} like the first chunk"
                )
            yield as_chunk(arr, self.n_sensors, name=name)


def open_source(predictions, n_sensors: int, chunk_rows: int | None = None) -> Source:
    if isinstance(predictions, bytes):  # a path as bytes, as os.listdir(b".") gives them
        predictions = os.fsdecode(predictions)
    if isinstance(predictions, (str, os.PathLike)):
        return FileSource(predictions, n_sensors, chunk_rows)
    if _is_array_like(predictions):
        return ArraySource(predictions, n_sensors, chunk_rows)
    if isinstance(predictions, Iterable):
        return IterableSource(predictions, n_sensors)
    raise TypeError(
        "predictions: expected a 2-D array, a path to a .npy file or an iterable of 2-D chunks, "
        f"got {type(predictions).__name__}"
    )


def iter_chunks(predictions, n_sensors: int, chunk_rows: int | None = None) -> Iterator[np.ndarray]:
    """Checked chunks in instance order; a file is read chunk by chunk."""
    return open_source(predictions, n_sensors, chunk_rows).chunks()


def skip_rows(blocks: Iterator[np.ndarray], start: int, skipped: Skipped | None,
              name: str) -> Iterator[np.ndarray]:
    """The rows of ``blocks`` (2-D arrays in order) from row ``start`` on.

    Skipped rows are consumed but not used, except that ``skipped`` sees all
    of them, so a resumed run can tell the input is the one it began with.
    """
    seen = 0
    for block in blocks:
        if seen >= start:
            yield block
            continue
        n = block.shape[0]
        take = min(n, start - seen)
        if skipped is not None and take:
            skipped(seen, block[:take])
        seen += n
        if seen > start:
            yield block[take:]
    if seen < start:
        raise ValueError(
            f"{name}: the input ended after {seen} instances, but the run being resumed had already "
            f"done {start}: it is not the input the run began with"
        )


def close(blocks) -> None:
    """Closes a generator of blocks now (a file's reader thread stops with
    it), rather than at garbage collection; other iterables are left as they are."""
    stop = getattr(blocks, "close", None)
    if stop is not None:
        stop()


def _is_array_like(obj) -> bool:
    if isinstance(obj, np.ndarray) or hasattr(obj, "__array__"):
        return True
    # A list of rows is an array; a list of 2-D blocks is a sequence of chunks.
    if isinstance(obj, (list, tuple)):
        return len(obj) == 0 or np.ndim(obj[0]) < 2
    return False
