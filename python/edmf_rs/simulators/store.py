"""The prediction store: every evaluated instance, kept as it arrives.

One folder per model and sampling (``store/<key>/``, the key a hash of their
fingerprint) holds a ``manifest.json`` (the fingerprint, parameter and sensor
names) and one Parquet file per flushed range of instances,
``part-<first>-<count>.parquet``, each written atomically (temporary file,
fsync, rename): a killed run leaves only whole parts, and the next run with
the same model and sampling reuses them and evaluates only the rest. Since
all sensors' predictions are stored (excluded ones too), changing the
uncertainty sources, phi, the correction, the excluded sensors or the
measured values evaluates nothing again.

Why Parquet and not Zarr: the rows are appended in ranges of variable length
with a string column (the failure's reason); Parquet stores such a table per
file with pyarrow (already a dependency for candidates.parquet), whereas Zarr
wants fixed-shape numeric chunks and a resize per append, and a new dependency.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..stream.atomic import atomic_path, write_text

SCHEMA = "edmf_rs.prediction-store/1"
_PART = re.compile(r"part-(\d{12})-(\d{9})\.parquet$")


@dataclass(frozen=True, eq=False)
class StoredRows:
    """Rows ``first .. first + n - 1`` of a store: parameters, predictions (NaN where failed), failures."""

    first: int
    parameters: np.ndarray
    predictions: np.ndarray
    failed: np.ndarray
    reason: list
    stderr: list
    work: list


def store_key(fingerprint: dict) -> str:
    """The name of a model's store folder: a hash of its fingerprint (JSON, keys sorted)."""
    return hashlib.sha256(json.dumps(fingerprint, sort_keys=True, default=str).encode()).hexdigest()[:16]


class PredictionStore:
    """Parameters, predictions and failures of evaluated instances, in ``folder``.

    Parameters
    ----------
    root
        The store folder of a run (``<out>/store``); this model's part goes
        into ``root/<key>``.
    fingerprint
        JSON-serialisable description of the model and sampling; any change
        gives another key, so another model's predictions are never reused.
    parameters, sensors
        Column names.

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> s = PredictionStore(tempfile.mkdtemp(), {"model": "f"}, ("a",), ("S",))
    >>> s.append(0, np.array([[1.0], [2.0]]), np.array([[10.0], [np.nan]]), np.array([False, True]),
    ...          ["", "exit code 1"], ["", "boom"], ["", "work/instance-000000002"])
    >>> PredictionStore(s.root, {"model": "f"}, ("a",), ("S",)).covered()
    2
    """

    def __init__(self, root, fingerprint: dict, parameters, sensors):
        text = json.dumps(fingerprint, sort_keys=True, default=str)
        self.key = store_key(fingerprint)
        self.root = Path(root)
        self.folder = self.root / self.key
        self.parameters, self.sensors = tuple(parameters), tuple(sensors)
        manifest = self.folder / "manifest.json"
        if not manifest.is_file():
            self.folder.mkdir(parents=True, exist_ok=True)
            write_text(manifest, json.dumps({"schema": SCHEMA, "fingerprint": json.loads(text),
                                             "parameters": self.parameters, "sensors": self.sensors},
                                            indent=1) + "\n")
        self.parts = sorted((int(m.group(1)), int(m.group(2)), p) for p in self.folder.glob("part-*.parquet")
                            if (m := _PART.search(p.name)))
        self._cache: tuple[int, StoredRows] | None = None

    def covered(self) -> int:
        """How many instances from 0 on are stored without a gap."""
        end = 0
        for first, n, _ in self.parts:
            if first > end:
                break
            end = max(end, first + n)
        return end

    def append(self, first: int, parameters, predictions, failed, reason, stderr, work) -> None:
        """Writes rows ``first ..`` as one part, atomically."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        n = len(failed)
        if n == 0:
            return
        columns = {"instance": pa.array(np.arange(first, first + n, dtype=np.int64))}
        columns.update({f"p:{name}": pa.array(parameters[:, j]) for j, name in enumerate(self.parameters)})
        columns.update({f"s:{name}": pa.array(predictions[:, j]) for j, name in enumerate(self.sensors)})
        columns.update(failed=pa.array(np.asarray(failed, bool)), reason=pa.array(list(reason), pa.string()),
                       stderr=pa.array(list(stderr), pa.string()), work=pa.array(list(work), pa.string()))
        path = self.folder / f"part-{first:012d}-{n:09d}.parquet"
        with atomic_path(path) as tmp:
            pq.write_table(pa.table(columns), tmp, compression="zstd")
        self.parts.append((first, n, path))
        self.parts.sort()

    def read(self, first: int, n: int) -> StoredRows | None:
        """Stored rows ``first .. first + n - 1``, or None unless all of them are stored."""
        if first + n > self.covered():
            return None
        pieces = []
        for start, count, path in self.parts:
            lo, hi = max(first, start), min(first + n, start + count)
            if lo >= hi:
                continue
            rows = self._load(start, path)
            pieces.append((lo, _slice(rows, lo - start, hi - start)))
        pieces.sort(key=lambda p: p[0])
        # Parts may overlap only when a batch was evaluated twice: keep the first copy of each row.
        out, end = [], first
        for lo, rows in pieces:
            if lo + len(rows.failed) <= end:
                continue
            out.append(_slice(rows, end - lo, len(rows.failed)))
            end = lo + len(rows.failed)
        return StoredRows(first, np.concatenate([r.parameters for r in out]),
                          np.concatenate([r.predictions for r in out]), np.concatenate([r.failed for r in out]),
                          sum((r.reason for r in out), []), sum((r.stderr for r in out), []),
                          sum((r.work for r in out), []))

    def _load(self, start: int, path: Path) -> StoredRows:
        if self._cache is not None and self._cache[0] == start:
            return self._cache[1]
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        col = lambda name: table.column(name).to_numpy()  # noqa: E731
        rows = StoredRows(
            start, np.column_stack([col(f"p:{n}") for n in self.parameters]).astype(np.float64),
            np.column_stack([col(f"s:{n}") for n in self.sensors]).astype(np.float64),
            col("failed").astype(bool), table.column("reason").to_pylist(), table.column("stderr").to_pylist(),
            table.column("work").to_pylist())
        self._cache = (start, rows)
        return rows


def _slice(rows: StoredRows, lo: int, hi: int) -> StoredRows:
    return StoredRows(rows.first + lo, rows.parameters[lo:hi], rows.predictions[lo:hi], rows.failed[lo:hi],
                      rows.reason[lo:hi], rows.stderr[lo:hi], rows.work[lo:hi])
