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

A part holds no column for a sensor the model did not provide (an excluded
sensor missing from a named output): such rows are read back with that
sensor *absent*, never as predictions. A failed instance keeps the
``timeout`` it ran under when it timed out (NaN otherwise), so a later run
with a longer timeout can tell it might now succeed. Instances run again
(retried failures) go to ``retry-<seq>.parquet`` files holding an
``instance`` column; the latest retry of an instance replaces its row.
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
_RETRY = re.compile(r"retry-(\d{9})\.parquet$")
_TIMED_OUT = re.compile(r"^timed out after ([0-9.eE+-]+) s")


@dataclass(frozen=True, eq=False)
class StoredRows:
    """Rows ``first .. first + n - 1`` of a store: parameters, predictions (NaN where failed), failures,
    the timeout a timed-out run had (NaN otherwise) and the sensors the model did not provide."""

    first: int
    parameters: np.ndarray
    predictions: np.ndarray
    failed: np.ndarray
    reason: list
    stderr: list
    work: list
    timeout: np.ndarray | None = None
    absent: tuple = ()

    def __post_init__(self):
        if self.timeout is None:  # parts written before the column: read it from the reason
            object.__setattr__(self, "timeout", np.array([timed_out_after(r) for r in self.reason], dtype=float))


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

    #: Format written to manifest.json (a subclass with other rows sets its own).
    schema = SCHEMA

    def __init__(self, root, fingerprint: dict, parameters, sensors):
        text = json.dumps(fingerprint, sort_keys=True, default=str)
        self.key = store_key(fingerprint)
        self.root = Path(root)
        self.folder = self.root / self.key
        self.parameters, self.sensors = tuple(parameters), tuple(sensors)
        manifest = self.folder / "manifest.json"
        if not manifest.is_file():
            self.folder.mkdir(parents=True, exist_ok=True)
            write_text(manifest, json.dumps({"schema": self.schema, "fingerprint": json.loads(text),
                                             "parameters": self.parameters, "sensors": self.sensors},
                                            indent=1) + "\n")
        self.parts = sorted((int(m.group(1)), int(m.group(2)), p) for p in self.folder.glob("part-*.parquet")
                            if (m := _PART.search(p.name)))
        self._cache: tuple[int, StoredRows] | None = None
        self.retries = sorted((int(m.group(1)), p) for p in self.folder.glob("retry-*.parquet")
                              if (m := _RETRY.search(p.name)))
        self._retried: dict[int, tuple] | None = None

    def save_outputs(self, names) -> None:
        """Records the names of a Python model's outputs (None: a bare array), once."""
        path = self.folder / "outputs.json"
        if not path.is_file():
            write_text(path, json.dumps({"names": None if names is None else list(names)}) + "\n")

    def outputs(self):
        """The recorded output names (None: a bare array), or False when none were recorded."""
        try:
            names = json.loads((self.folder / "outputs.json").read_text(encoding="utf-8"))["names"]
        except (OSError, ValueError, KeyError, TypeError):
            return False
        return names if names is None or all(isinstance(n, str) for n in names) else False

    def covered(self) -> int:
        """How many instances from 0 on are stored without a gap."""
        end = 0
        for first, n, _ in self.parts:
            if first > end:
                break
            end = max(end, first + n)
        return end

    def append(self, first: int, parameters, predictions, failed, reason, stderr, work, *, timeout=None,
               absent=(), instances=None) -> None:
        """Writes rows ``first ..`` as one part, atomically; with ``instances``
        (any indices), as a retry file whose rows replace earlier ones."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        n = len(failed)
        if n == 0:
            return
        index = np.arange(first, first + n, dtype=np.int64) if instances is None else np.asarray(instances, np.int64)
        timeout = np.full(n, np.nan) if timeout is None else np.asarray(timeout, dtype=float)
        columns = {"instance": pa.array(index)}
        columns.update({f"p:{name}": pa.array(parameters[:, j]) for j, name in enumerate(self.parameters)})
        columns.update({f"s:{name}": pa.array(predictions[:, j]) for j, name in enumerate(self.sensors)
                        if name not in absent})
        columns.update(failed=pa.array(np.asarray(failed, bool)), reason=pa.array(list(reason), pa.string()),
                       stderr=pa.array(list(stderr), pa.string()), work=pa.array(list(work), pa.string()),
                       timeout=pa.array(timeout))
        if instances is None:
            path = self.folder / f"part-{first:012d}-{n:09d}.parquet"
        else:
            seq = self.retries[-1][0] + 1 if self.retries else 0
            path = self.folder / f"retry-{seq:09d}.parquet"
        with atomic_path(path) as tmp:
            pq.write_table(pa.table(columns), tmp, compression="zstd")
        if instances is None:
            self.parts.append((first, n, path))
            self.parts.sort()
        else:
            self.retries.append((seq, path))
            self._retried = None

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
        rows = StoredRows(first, np.concatenate([r.parameters for r in out]),
                          np.concatenate([r.predictions for r in out]), np.concatenate([r.failed for r in out]),
                          sum((r.reason for r in out), []), sum((r.stderr for r in out), []),
                          sum((r.work for r in out), []), np.concatenate([r.timeout for r in out]),
                          tuple(sorted({s for r in out for s in r.absent})))
        return self._with_retries(rows)

    def _with_retries(self, rows: StoredRows) -> StoredRows:
        """``rows`` with the latest retry of each of its instances in place of the first run."""
        if not self.retries:
            return rows
        if self._retried is None:
            self._retried = {}
            for _, path in self.retries:  # in order: a later retry replaces an earlier one
                part = self._read_table(path)
                keys = ("parameters", "predictions", "failed", "reason", "stderr", "work", "timeout")
                for i, instance in enumerate(part["instance"]):
                    self._retried[int(instance)] = tuple(part[k][i] for k in keys) + (part["absent"],)
        n = len(rows.failed)
        hits = [(i, self._retried[rows.first + i]) for i in range(n) if rows.first + i in self._retried]
        if not hits:
            return rows
        reason, stderr, work = list(rows.reason), list(rows.stderr), list(rows.work)
        params, preds, failed, timeout = (rows.parameters.copy(), rows.predictions.copy(), rows.failed.copy(),
                                          rows.timeout.copy())
        absent = set(rows.absent)
        for i, (p, s, f, r, e, w, t, a) in hits:
            params[i], preds[i], failed[i], reason[i], stderr[i], work[i], timeout[i] = p, s, f, r, e, w, t
            absent.update(a)
        return StoredRows(rows.first, params, preds, failed, reason, stderr, work, timeout, tuple(sorted(absent)))

    def _load(self, start: int, path: Path) -> StoredRows:
        if self._cache is not None and self._cache[0] == start:
            return self._cache[1]
        part = self._read_table(path)
        rows = StoredRows(start, part["parameters"], part["predictions"], part["failed"], part["reason"],
                          part["stderr"], part["work"], part["timeout"], part["absent"])
        self._cache = (start, rows)
        return rows

    def _read_table(self, path: Path) -> dict:
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        n = table.num_rows
        col = lambda name: table.column(name).to_numpy()  # noqa: E731
        absent = tuple(s for s in self.sensors if f"s:{s}" not in table.column_names)
        reason = table.column("reason").to_pylist()
        return {
            "instance": col("instance"),
            "parameters": np.column_stack([col(f"p:{n}") for n in self.parameters]).astype(np.float64),
            "predictions": np.column_stack([col(f"s:{s}").astype(np.float64) if s not in absent else np.full(n, np.nan)
                                            for s in self.sensors]).reshape(n, len(self.sensors)),
            "failed": col("failed").astype(bool), "reason": reason, "stderr": table.column("stderr").to_pylist(),
            "work": table.column("work").to_pylist(),
            "timeout": (col("timeout").astype(float) if "timeout" in table.column_names
                        else np.array([timed_out_after(r) for r in reason], dtype=float)),
            "absent": absent,
        }


def timed_out_after(reason: str) -> float:
    """The timeout in a failure's reason (``timed out after 2 s ...``), else NaN."""
    m = _TIMED_OUT.match(reason or "")
    return float(m.group(1)) if m else np.nan


def _slice(rows: StoredRows, lo: int, hi: int) -> StoredRows:
    return StoredRows(rows.first + lo, rows.parameters[lo:hi], rows.predictions[lo:hi], rows.failed[lo:hi],
                      rows.reason[lo:hi], rows.stderr[lo:hi], rows.work[lo:hi], rows.timeout[lo:hi], rows.absent)
