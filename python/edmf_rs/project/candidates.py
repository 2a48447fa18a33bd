"""The candidate model set of a run, streamed to ``candidates.parquet`` as it is found.

A run may leave millions of candidates (the cantilever's 2^23 Sobol'
instances leave 4.9 million, 430 MB of parameters and predictions), so they
are never held in memory: each batch's candidates are appended to the Parquet
file as one row group, and what the summary and the report need is kept
alongside, in memory that does not grow with N nor with the candidates:

- exact streaming summaries: the number of candidates and each parameter's
  min and max over them;
- a bounded, deterministic sample for the plots: the ``SAMPLE`` candidates
  whose hashed instance index (splitmix64) is smallest ("bottom-k"
  sampling). It depends only on which instances are candidates, not on the
  batch size, the order of the batches or the thread count, and is a uniform
  random sample of the candidates (the hash is fixed: same run, same sample);
- the candidates' instance indices, in an unlinked temporary file mapped into
  memory (``numpy.memmap``): ``falsification.candidate_indices`` reads like an
  array but occupies memory only for the pages that are read.

The Parquet file is written under a temporary name beside its target and
renamed only by :meth:`CandidateSet.save`, so an interrupted run never leaves
a ``candidates.parquet`` that looks complete.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import uuid
import weakref
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..stream.atomic import atomic_path

#: Candidates kept for the plots (bottom-k of the hashed instance index).
SAMPLE = 2000


def sample_keys(indices: np.ndarray) -> np.ndarray:
    """splitmix64 of each instance index: the sampling key of bottom-k sampling.

    Parameters
    ----------
    indices : array_like of int
        Instance indices (>= 0).

    Returns
    -------
    numpy.ndarray
        uint64 keys, a bijection of the indices that looks uniformly random.

    Examples
    --------
    >>> sample_keys([0, 1]).tolist() == sample_keys([0, 1]).tolist()
    True
    >>> int(sample_keys([0])[0]) != int(sample_keys([1])[0])
    True
    """
    z = np.asarray(indices, dtype=np.uint64) + np.uint64(0x9E3779B97F4A7C15)
    with np.errstate(over="ignore"):
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def mapped(file, count: int, dtype) -> np.ndarray:
    """A read-only array of the first ``count`` values of an open binary file, memory-mapped.

    Parameters
    ----------
    file : file object
        Opened for reading and writing (e.g. ``tempfile.TemporaryFile()``); flushed first.
    count : int
        Number of values.
    dtype : numpy dtype
        Their type.

    Returns
    -------
    numpy.ndarray
        A read-only ``numpy.memmap`` (an empty array when ``count`` is 0).

    Examples
    --------
    >>> import tempfile
    >>> f = tempfile.TemporaryFile()
    >>> _ = f.write(np.arange(3, dtype=np.int64).tobytes())
    >>> mapped(f, 3, np.int64).tolist()
    [0, 1, 2]
    """
    if count == 0:
        arr = np.empty(0, dtype=dtype)
    else:
        file.flush()
        arr = np.memmap(file, dtype=dtype, mode="r", shape=(count,))
    arr.flags.writeable = False
    return arr


def remove_stale(folder: Path) -> None:
    """Removes the temporary candidate files of runs that were killed (their process is gone)."""
    for leftover in folder.glob(".candidates.parquet.*.tmp"):
        try:
            pid = int(leftover.name.split(".")[3])
        except (IndexError, ValueError):
            continue
        if pid == os.getpid():
            continue
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            leftover.unlink(missing_ok=True)
        except OSError:  # alive under another user, or no way to tell: keep it
            pass


class _File:
    """Where the Parquet file is now; removes it when it is still a temporary file nobody saved."""

    def __init__(self, path: Path, temporary_folder: Path | None):
        self.path, self.temporary_folder, self.saved = path, temporary_folder, False

    def discard(self) -> None:
        if not self.saved:
            Path(self.path).unlink(missing_ok=True)
        if self.temporary_folder is not None:
            shutil.rmtree(self.temporary_folder, ignore_errors=True)


@dataclass(frozen=True, eq=False)
class CandidateSet:
    """The candidates of a run: in a Parquet file, with exact summaries and a bounded sample.

    Attributes
    ----------
    parameter_names, sensor_names : tuple of str
        The columns after ``instance``.
    count : int
        Number of candidates.
    ranges : dict
        Parameter name -> (min, max) over every candidate (exact), or None
        without candidates.
    sample_index, sample_parameters, sample_predictions : numpy.ndarray
        Up to ``SAMPLE`` candidates (bottom-k of the hashed instance index),
        in instance order, for the plots.

    Examples
    --------
    >>> import numpy as np
    >>> w = CandidateWriter(None, ("a",), ("S",))
    >>> w.add(np.array([3, 7]), np.array([[1.0], [2.0]]), np.array([[0.1], [0.2]]))
    >>> cs = w.finish()
    >>> cs.count, cs.ranges, cs.frame().index.tolist()
    (2, {'a': (1.0, 2.0)}, [3, 7])
    """

    parameter_names: tuple[str, ...]
    sensor_names: tuple[str, ...]
    count: int
    ranges: dict
    sample_index: np.ndarray
    sample_parameters: np.ndarray
    sample_predictions: np.ndarray
    file: _File = field(repr=False)

    @property
    def path(self) -> Path:
        """The Parquet file as it is now (a temporary name until `save`)."""
        return Path(self.file.path)

    def frame(self):
        """Every candidate as a DataFrame indexed by instance (reads the whole file).

        Returns
        -------
        pandas.DataFrame
            Columns: the parameters, then the sensors.

        Examples
        --------
        >>> w = CandidateWriter(None, ("a",), ("S",))
        >>> w.add([4], np.array([[1.0]]), np.array([[2.0]]))
        >>> w.finish().frame().to_dict("index")
        {4: {'a': 1.0, 'S': 2.0}}
        """
        import pyarrow.parquet as pq

        frame = pq.read_table(self.path).to_pandas()
        return frame.set_index("instance")

    def parameters(self) -> np.ndarray:
        """The candidates' parameters, read from the file.

        Returns
        -------
        numpy.ndarray
            float64 (n_c, p), in instance order.

        Examples
        --------
        >>> w = CandidateWriter(None, ("a", "b"), ("S",))
        >>> w.add([0, 2], np.array([[1.0, 2.0], [3.0, 4.0]]), np.zeros((2, 1)))
        >>> w.finish().parameters().tolist()
        [[1.0, 2.0], [3.0, 4.0]]
        """
        import pyarrow.parquet as pq

        table = pq.read_table(self.path, columns=list(self.parameter_names))
        return np.column_stack([table.column(n).to_numpy() for n in self.parameter_names]).reshape(
            table.num_rows, len(self.parameter_names)).astype(np.float64)

    def save(self, target: str | os.PathLike) -> Path:
        """Puts the file at ``target``: renamed when it is a temporary file in the same folder, else copied.

        Parameters
        ----------
        target : path
            E.g. ``out/candidates.parquet``; written atomically.

        Returns
        -------
        pathlib.Path
            ``target``.

        Raises
        ------
        OSError
            If the file cannot be renamed or copied.

        Examples
        --------
        >>> import tempfile, pathlib
        >>> cs = CandidateWriter(None, ("a",), ("S",)).finish()
        >>> cs.save(pathlib.Path(tempfile.mkdtemp()) / "candidates.parquet").name
        'candidates.parquet'
        """
        target = Path(target)
        here = self.path
        if here.resolve() == target.resolve():
            return target
        if not self.file.saved and here.parent.resolve() == target.parent.resolve():
            os.replace(here, target)
            self.file.path, self.file.saved = target, True
            return target
        with atomic_path(target) as tmp:
            shutil.copyfile(here, tmp)
        return target


class CandidateWriter:
    """Appends candidates to a Parquet file, batch by batch, keeping only bounded summaries.

    Parameters
    ----------
    folder : path or None
        Where the file is written (under a temporary name, renamed by
        `CandidateSet.save`); None: a temporary folder, removed with the
        CandidateSet.
    parameter_names, sensor_names : sequence of str
        Column names.
    sample : int
        Candidates kept for the plots.

    Examples
    --------
    >>> import numpy as np
    >>> w = CandidateWriter(None, ("a", "b"), ("S",), sample=1)
    >>> w.add(np.array([0, 5]), np.array([[1.0, 4.0], [2.0, 3.0]]), np.array([[0.0], [0.0]]))
    >>> cs = w.finish()
    >>> cs.ranges["b"], cs.sample_index.size
    ((3.0, 4.0), 1)
    """

    def __init__(self, folder, parameter_names, sensor_names, *, sample: int = SAMPLE):
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.parameter_names, self.sensor_names = tuple(parameter_names), tuple(sensor_names)
        temporary = None
        if folder is None:
            folder = temporary = Path(tempfile.mkdtemp(prefix="edmf-rs-candidates-"))
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        remove_stale(folder)
        path = folder / f".candidates.parquet.{os.getpid()}.{uuid.uuid4().hex}.tmp"
        self.file = _File(path, temporary)
        self.schema = pa.schema([("instance", pa.int64())] + [(n, pa.float64()) for n in self.parameter_names]
                                + [(n, pa.float64()) for n in self.sensor_names])
        self.writer = pq.ParquetWriter(path, self.schema, compression="zstd")
        self.indices = tempfile.TemporaryFile(prefix="edmf-rs-candidate-indices-")
        self.count = 0
        p = len(self.parameter_names)
        self.low, self.high = np.full(p, np.inf), np.full(p, -np.inf)
        self.limit = sample
        self.sample = (np.empty(0, np.uint64), np.empty(0, np.int64), np.empty((0, p)),
                       np.empty((0, len(self.sensor_names))))

    def add(self, indices, parameters, predictions) -> None:
        """Appends one batch of candidates (instance indices, parameters, predictions) as a row group."""
        import pyarrow as pa

        indices = np.asarray(indices, dtype=np.int64)
        if indices.size == 0:
            return
        theta = np.asarray(parameters, dtype=np.float64)
        preds = np.asarray(predictions, dtype=np.float64)
        columns = [pa.array(indices)] + [pa.array(theta[:, j]) for j in range(theta.shape[1])] + \
            [pa.array(preds[:, j]) for j in range(preds.shape[1])]
        self.writer.write_table(pa.Table.from_arrays(columns, schema=self.schema))
        self.indices.write(indices.tobytes())
        self.count += indices.size
        self.low = np.minimum(self.low, theta.min(axis=0))
        self.high = np.maximum(self.high, theta.max(axis=0))
        keys, idx, par, pre = self.sample
        keys = np.concatenate([keys, sample_keys(indices)])
        idx, par, pre = np.concatenate([idx, indices]), np.vstack([par, theta]), np.vstack([pre, preds])
        if keys.size > self.limit:
            keep = np.argpartition(keys, self.limit - 1)[:self.limit] if self.limit else np.empty(0, np.intp)
            keys, idx, par, pre = keys[keep], idx[keep], par[keep], pre[keep]
        self.sample = (keys, idx, par.copy(), pre.copy())  # copies: never views of a whole batch

    def candidate_indices(self) -> np.ndarray:
        """Every candidate's instance index so far, memory-mapped (read-only int64)."""
        return mapped(self.indices, self.count, np.int64)

    def finish(self) -> CandidateSet:
        """Closes the file; returns the candidate set (the file still under its temporary name)."""
        self.writer.close()
        self.indices.close()  # candidate_indices() arrays map it on their own
        _, idx, par, pre = self.sample
        order = np.argsort(idx, kind="stable")
        ranges = {n: (float(lo), float(hi)) if self.count else None
                  for n, lo, hi in zip(self.parameter_names, self.low, self.high)}
        cs = CandidateSet(self.parameter_names, self.sensor_names, self.count, ranges, idx[order], par[order],
                          pre[order], self.file)
        weakref.finalize(cs, self.file.discard)
        return cs

    def abort(self) -> None:
        """Closes and removes the unfinished file (after an error or Ctrl-C)."""
        try:
            self.writer.close()
        finally:
            self.indices.close()
            self.file.discard()


__all__ = ["SAMPLE", "CandidateSet", "CandidateWriter", "mapped", "remove_stale", "sample_keys"]
