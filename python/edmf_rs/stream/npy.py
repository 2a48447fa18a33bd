"""Chunked reading of ``.npy`` files of any size.

Rows are read with positional reads into two reused buffers by a reader
thread (a helper thread reads half of each chunk), so reading chunk k+1
overlaps the caller's work on chunk k (both release the GIL) and memory stays
a few chunks whatever the file size. ``np.load`` and
memory maps are avoided on purpose: mapped pages count towards the process's
resident memory as a whole file streams through.
"""

from __future__ import annotations

import os
import queue
import stat
import threading
from collections.abc import Iterator

import numpy as np
from numpy.lib import format as npy_format

#: Bytes of predictions per chunk read from disk (as float32/float64): two such
#: buffers are live. Measured on a 2-core VM streaming a warm float32 file:
#: 4 MiB chunks run at 0.71 of NumPy's chunked readinto (per-chunk hand-offs
#: cost), 16 MiB at 0.89; 32 MiB is slower again (no longer in cache).
CHUNK_BYTES = 16 * 2**20
#: Chunks after the one being read that the OS is asked to fetch meanwhile.
AHEAD = 4
#: Reads at least this large are split between the reader thread and a helper.
SPLIT_BYTES = 2**20
#: Positional reads (POSIX) are what let two threads read one file at once.
_PREADV = hasattr(os, "preadv")


def open_regular(path, name: str):
    """``path`` opened for unbuffered binary reading, refused (ValueError
    naming ``name``) unless it is a regular file: a FIFO would block the run
    until some writer appears, a device never ends."""
    try:  # O_NONBLOCK: opening a FIFO returns at once instead of waiting for a writer
        fd = os.open(os.fspath(path), os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except OSError as exc:
        raise ValueError(f"{name}: cannot open {path!s}: {exc.strerror}") from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError(f"{name}: {path!s} is not a regular file (a FIFO, device or socket "
                             "cannot be read in place); give a .npy file")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        return open(fd, "rb", buffering=0)
    except BaseException:
        os.close(fd)
        raise


class NpyFile:
    """An open, checked 2-D numeric ``.npy`` file: ``shape``, ``dtype``, ``fortran``."""

    def __init__(self, path, name: str = "predictions"):
        self.path, self.name = path, name
        self.helper: _Helper | None = None  # reads half of each large read
        self.busy = False  # reader threads may still be using the file
        self.fp = open_regular(path, name)
        try:
            self.shape, self.fortran, self.dtype = self._header()
            if self.dtype.kind not in "iufb" or self.dtype.hasobject or self.dtype.fields:
                raise TypeError(f"{name}: expected a numeric .npy file, {path!s} holds dtype {self.dtype}")
            if len(self.shape) != 2 or min(self.shape) < 0:
                raise ValueError(
                    f"{name}: expected a 2-D array (instances x sensors) in {path!s}, its header gives shape {self.shape}"
                )
            self.offset = self.fp.tell()
            expected = self.shape[0] * self.shape[1] * self.dtype.itemsize
            found = os.fstat(self.fp.fileno()).st_size - self.offset
            if found < expected:
                raise ValueError(
                    f"{name}: {path!s} is truncated: its header promises {expected} bytes of data, "
                    f"found {found}"
                )
        except BaseException:
            self.fp.close()
            raise
        if hasattr(os, "posix_fadvise"):  # ask for aggressive read-ahead on cold files
            os.posix_fadvise(self.fp.fileno(), 0, 0, os.POSIX_FADV_SEQUENTIAL)

    def _header(self):
        try:
            version = npy_format.read_magic(self.fp)
            if version == (1, 0):
                return npy_format.read_array_header_1_0(self.fp)
            if version in ((2, 0), (3, 0)):
                return npy_format.read_array_header_2_0(self.fp)
            raise ValueError(f"unsupported .npy format version {version}")
        except Exception as exc:  # numpy's parser raises several types on garbage
            raise ValueError(f"{self.name}: {self.path!s} is not a readable .npy file ({exc})") from None

    @property
    def n_rows(self) -> int:
        return int(self.shape[0])

    @property
    def n_cols(self) -> int:
        return int(self.shape[1])

    def close(self) -> None:
        self.fp.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def read_into(self, out: np.ndarray, first: int) -> None:
        """Fills ``out`` (rows x cols, file dtype and order) with rows ``first..``."""
        size = self.dtype.itemsize
        if self.fortran:  # each column of a Fortran file is contiguous on disk
            for j in range(self.n_cols):
                self._fill(out[:, j], self.offset + (j * self.n_rows + first) * size)
        else:
            self._fill(out, self.offset + first * self.n_cols * size)

    def will_need(self, first: int, count: int) -> None:
        """Asks the OS to start reading rows ``first..first+count`` now, so a
        cold file keeps the disk busy while the current chunk is processed."""
        if not hasattr(os, "posix_fadvise") or count <= 0:
            return
        size = self.dtype.itemsize
        columns = range(self.n_cols) if self.fortran else [0]
        span = count * size if self.fortran else count * self.n_cols * size
        for j in columns:
            start = self.offset + ((j * self.n_rows + first) * size if self.fortran else first * self.n_cols * size)
            os.posix_fadvise(self.fp.fileno(), start, span, os.POSIX_FADV_WILLNEED)

    def rows(self, first: int, count: int) -> np.ndarray:
        """Rows ``first..first+count`` as a native float array (a fresh copy)."""
        out = np.empty((count, self.n_cols), dtype=self.dtype, order="F" if self.fortran else "C")
        self.read_into(out, first)
        return native(out)

    def _fill(self, out: np.ndarray, position: int) -> None:
        view = memoryview(out).cast("B")
        if self.helper is not None and view.nbytes >= SPLIT_BYTES:
            # Copying out of the page cache is what limits a warm file: two
            # threads copy twice as much while the kernel works on a chunk.
            half = view.nbytes // 2
            self.helper.submit(self._read_exact, view[half:], position + half)
            try:
                self._read_exact(view[:half], position)
            finally:
                self.helper.result()  # never leave the helper writing into a buffer
        else:
            self._read_exact(view, position)

    def _read_exact(self, view: memoryview, position: int) -> None:
        done = 0
        while done < view.nbytes:  # a read may return fewer bytes than asked
            if _PREADV:
                got = os.preadv(self.fp.fileno(), [view[done:]], position + done)
            else:
                self.fp.seek(position + done)
                got = self.fp.readinto(view[done:])
            if not got:
                raise ValueError(f"{self.name}: {self.path!s} ended early (it was truncated while being read)")
            done += got


def native(block: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """float32/float64 in native byte order, converting in place where possible."""
    if block.dtype in (np.float32, np.float64) and block.dtype.isnative:
        return block
    if block.dtype.kind == "f" and block.dtype.itemsize in (4, 8):  # other byte order
        block.byteswap(inplace=True)
        return block.view(block.dtype.newbyteorder("="))
    if out is None:
        out = np.empty(block.shape, dtype=np.float64, order="F" if block.flags.f_contiguous else "C")
    np.copyto(out, block, casting="unsafe")
    return out


class _Helper:
    """A daemon thread running one read at a time for the reader thread (a
    daemon too, so a read stalled on a dead network share never holds up the
    interpreter's exit)."""

    def __init__(self):
        self.tasks: queue.Queue = queue.Queue()
        self.done: queue.Queue = queue.Queue()
        self.thread = threading.Thread(target=self._run, name="edmf-rs-npy-helper", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while (task := self.tasks.get()) is not None:
            fn, args = task
            try:
                fn(*args)
                self.done.put(None)
            except BaseException as exc:  # re-raised by result()
                self.done.put(exc)

    def submit(self, fn, *args) -> None:
        self.tasks.put((fn, args))

    def result(self) -> None:
        exc = self.done.get()
        if exc is not None:
            raise exc

    def stop(self, wait: bool) -> None:
        self.tasks.put(None)
        if wait:
            self.thread.join()


class _Slot:
    """One read buffer (file dtype) and, for non-float files, its float64 copy."""

    def __init__(self, f: NpyFile, rows: int):
        order = "F" if f.fortran else "C"
        self.raw = np.empty((rows, f.n_cols), dtype=f.dtype, order=order)
        needs_copy = not (f.dtype.kind == "f" and f.dtype.itemsize in (4, 8))
        self.converted = np.empty((rows, f.n_cols), dtype=np.float64, order=order) if needs_copy else None

    def fill(self, f: NpyFile, first: int, count: int) -> np.ndarray:
        raw = self.raw[:count]
        f.read_into(raw, first)
        return native(raw, None if self.converted is None else self.converted[:count])


_END = object()


def read_chunks(path, chunk_rows: int | None = None, name: str = "predictions",
                start: int = 0, stop: int | None = None) -> Iterator[np.ndarray]:
    """Yields consecutive row blocks of a .npy file from row ``start`` to
    ``stop`` (default: the end), as native float32/float64 arrays (integers
    become float64).

    Each yielded array is a reused buffer, valid until the next one is asked
    for; meanwhile a reader thread fills the other buffer.
    """
    f = NpyFile(path, name)
    try:
        yield from _prefetched(f, chunk_rows, start, f.n_rows if stop is None else min(stop, f.n_rows))
    finally:
        if not f.busy:  # else the reader threads still read it; they are daemons
            f.close()


def _prefetched(f: NpyFile, chunk_rows: int | None, start: int, n: int) -> Iterator[np.ndarray]:
    # Integer files are converted to float64: size the chunk by the larger copy.
    item = f.dtype.itemsize if f.dtype.kind == "f" and f.dtype.itemsize in (4, 8) else 8
    rows = chunk_rows or max(1024, CHUNK_BYTES // max(1, f.n_cols * item))
    rows = max(1, min(rows, n - start))
    if start >= n:
        return
    free: queue.Queue = queue.Queue()
    full: queue.Queue = queue.Queue()
    for _ in range(2):
        free.put(_Slot(f, rows))
    stop = threading.Event()
    if _PREADV:
        f.helper = _Helper()

    def reader() -> None:
        try:
            for first in range(start, n, rows):
                ahead = first + rows
                f.will_need(ahead, min(AHEAD * rows, n - ahead))
                slot = free.get()
                if slot is None or stop.is_set():
                    return
                full.put((slot.fill(f, first, min(rows, n - first)), slot))
            full.put(_END)
        except BaseException as exc:  # handed to the consumer, raised there
            full.put(exc)

    thread = threading.Thread(target=reader, name="edmf-rs-npy-reader", daemon=True)
    thread.start()
    try:
        while True:
            item = full.get()
            if item is _END:
                return
            if isinstance(item, BaseException):
                raise item
            block, slot = item
            yield block
            free.put(slot)  # the caller is done with it: the reader may refill it
    finally:
        stop.set()
        free.put(None)
        f.busy = True
        try:
            thread.join()  # a Ctrl-C here leaves the file open for the threads
            f.busy = False
        finally:
            if f.helper is not None:
                f.helper.stop(wait=not f.busy)
                f.helper = None
