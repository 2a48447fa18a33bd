"""Resumable runs: a folder holding what a long run has found so far.

The folder holds the candidates as ``.npy`` parts (one set per checkpoint)
and a small ``state.json``: the position reached, the counts so far and a
fingerprint of the inputs. Parts are written first and the state replaced
last, each atomically, so after a crash, SIGKILL, Ctrl-C or full disk the
folder always describes a consistent prefix of the run, and running the same
call again continues from its end.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import numbers
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from . import atomic, chunks
from .folder_lock import FolderLock, folder_path

STATE = "state.json"
FORMAT = "edmf_rs.checkpoint/1"
#: Fingerprint entries that are content hashes (not worth printing).
HASHED = ("measurements", "thresholds")


class CheckpointError(OSError):
    """Writing a checkpoint failed; the folder keeps its previous state.

    Raised by `falsify` and `falsify_model` with ``checkpoint=`` when a save
    fails (a full disk, a folder made read-only during the run). Running the
    same call again once the problem is fixed resumes from the last state
    saved. An ``OSError``, so ``except OSError`` catches it too.

    Attributes
    ----------
    errno : int
        The operating system's error number of the failed write.
    strerror : str
        The message: which file could not be written, and how to resume.

    Examples
    --------
    >>> import errno
    >>> import edmf_rs
    >>> exc = edmf_rs.CheckpointError(errno.ENOSPC, "checkpoint: could not write state.json")
    >>> isinstance(exc, OSError), exc.errno == errno.ENOSPC
    (True, True)
    """


def digest(*arrays) -> str:
    """Short content hash of arrays, independent of their dtype and layout."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=np.float64)
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:32]


def fingerprint(call: str, measurements: np.ndarray, thresholds, **options) -> dict:
    """What must not change between a run and its resumption (``thresholds``:
    anything with ``n_sensors``, ``low`` and ``high``)."""
    return {"call": call, "n_sensors": thresholds.n_sensors, "measurements": digest(measurements),
            "thresholds": digest(thresholds.low, thresholds.high), **options}


def save_npy(target: Path, array: np.ndarray) -> None:
    with atomic.atomic_path(target) as tmp, open(tmp, "wb") as fh:
        np.lib.format.write_array(fh, np.asarray(array), allow_pickle=False)


def save_state(target: Path, text: str) -> None:
    atomic.write_text(target, text)


@contextlib.contextmanager
def deferred_sigint() -> Iterator[None]:
    """Holds Ctrl-C back until the block is done (main thread only), so a
    checkpoint is either written whole or not at all in memory as on disk."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if received:
            if callable(previous):
                previous(signal.SIGINT, None)
            elif previous != signal.SIG_IGN:
                raise KeyboardInterrupt


class Checkpoint:
    """A run's folder: reads the saved state, checks it belongs to this call,
    and appends the progress of the current accumulator.

    ``fields`` names the per-candidate or per-instance arrays saved besides
    the candidate indices (``n_violated``, ``parameters``, ``predictions``).
    """

    def __init__(self, folder, fp: dict, every: float, fields: tuple[str, ...] = (),
                 input_name: str = "predictions"):
        self.folder = folder_path(folder)
        if self.folder.exists() and not self.folder.is_dir():
            raise ValueError(f"checkpoint: expected a folder, {self.folder} is a file")
        self.every, self.fields, self.input_name = float(every), fields, input_name
        self.fingerprint = fp
        self._lock = FolderLock(self.folder)
        try:
            self._read_progress()
            unwritable = self._lock.unwritable
            if unwritable is not None and not self.complete:
                # Refused now, not at the first save after all the work.
                raise ValueError(f"checkpoint: cannot write in folder {self.folder} "
                                 f"({unwritable.strerror or unwritable}); give a writable folder")
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        """Releases the folder (idempotent)."""
        self._lock.release()

    def _read_progress(self) -> None:
        state = self._read_state()
        if state is not None:
            self._check(state["fingerprint"])
        state = state or {}
        self.n_done: int = state.get("n_done", 0)
        self.parts: list[dict] = state.get("parts", [])
        self.tally: dict | None = state.get("tally")
        self.first_row: str | None = state.get("first_row")
        self.last_row: str | None = state.get("last_row")
        self.complete: bool = state.get("complete", False)
        self.extra: dict = state.get("extra", {})
        # Instances and tally before this session's accumulator started.
        self.base, self._base_tally = self.n_done, self.tally
        self._seen = 0  # the accumulator's candidates already written
        self._last = time.monotonic()
        self.broken = False

    # -- reading -----------------------------------------------------------

    def _read_state(self) -> dict | None:
        path = self.folder / STATE
        if not path.exists():
            return None
        try:
            state = json.loads(path.read_text("utf-8"))
            if state.get("format") != FORMAT:
                raise ValueError(f"unknown format {state.get('format')!r}")
            _check_state(state)
            return state
        except (ValueError, AttributeError, UnicodeDecodeError) as exc:
            raise ValueError(
                f"checkpoint: {path} is not an edmf_rs checkpoint state ({exc}); "
                "pass another folder, or delete this one to start over"
            ) from None

    def _check(self, saved: dict) -> None:
        keys = sorted(set(saved) | set(self.fingerprint))
        differ = [k for k in keys if saved.get(k) != self.fingerprint.get(k)]
        if differ:
            shown = [f"{k}={saved.get(k)!r} now {self.fingerprint.get(k)!r}" for k in differ if k not in HASHED]
            raise ValueError(
                f"checkpoint: {self.folder} holds a run with other {', '.join(differ)}"
                + (f" ({'; '.join(shown)})" if shown else "")
                + "; resume it with the same inputs, or pass another folder (or delete this one) to start over"
            )

    def verify_row(self, index: int, row: np.ndarray) -> None:
        """Refuses to resume when a row already done differs from the saved run's."""
        expected = {0: self.first_row}
        if self.last_row is not None:
            expected[self.n_done - 1] = self.last_row
        if expected.get(index) is not None and digest(row) != expected[index]:
            raise ValueError(
                f"checkpoint: instance {index} of the {self.input_name} differs from the run saved in "
                f"{self.folder}: the input changed since; pass the same input to resume, or another "
                "folder (or delete this one) to start over"
            )

    def confirm_finished(self, remaining) -> None:
        """Before a finished run's saved result is returned: ``remaining`` is the
        input from instance ``n_done`` on (its skipped rows pass `verify_row`);
        any row left means the input is not the one the run finished."""
        try:
            for block in remaining:
                if len(block):
                    raise ValueError(
                        f"checkpoint: {self.folder} holds a finished run over {self.n_done} instances, but the "
                        f"{self.input_name} have more; pass the same input, or another folder to start over"
                    )
        finally:
            chunks.close(remaining)

    def confirm_first_row(self, blocks) -> None:
        """For an input that is not drained again (an iterable): its first
        instance, from the first non-empty block drawn, must be the saved run's."""
        try:
            for block in blocks:
                if len(block):
                    if self.n_done == 0:
                        raise ValueError(
                            f"checkpoint: {self.folder} holds a finished run over 0 instances, but the "
                            f"{self.input_name} have some; pass the same input, or another folder to start over"
                        )
                    self.verify_row(0, block[0])
                    return
            if self.n_done:
                raise ValueError(
                    f"checkpoint: {self.folder} holds a finished run over {self.n_done} instances, but the "
                    f"{self.input_name} are empty; pass the same input, or another folder to start over"
                )
        finally:
            chunks.close(blocks)

    def part_path(self, k: int, name: str) -> Path:
        return self.folder / f"part-{k:06d}.{name}.npy"

    def saved(self, n_sensors: int) -> dict[str, object]:
        """The finished run read back from the parts, as the keyword arguments
        of a ``FalsificationResult`` (without thresholds and measurements)."""
        names = ("candidates",) + self.fields
        pieces: dict[str, list[np.ndarray]] = {name: [] for name in names}
        for k, part in enumerate(self.parts):
            for name in names:
                arr = self._load(k, name)
                expected = part["n_instances"] if name == "n_violated" else part["n_candidates"]
                if arr.shape[0] != expected:
                    raise ValueError(f"checkpoint: {self.part_path(k, name)} is damaged "
                                     f"({arr.shape[0]} rows, expected {expected}); delete the folder to start over")
                pieces[name].append(arr)
        if sum(p["n_instances"] for p in self.parts) != self.n_done:
            raise ValueError(f"checkpoint: {self.folder / STATE} is inconsistent; delete the folder to start over")
        empty = {"candidates": np.empty(0, np.int64), "n_violated": np.empty(0, np.int32),
                 "parameters": np.empty((0, self.extra.get("n_parameters", 0))),
                 "predictions": np.empty((0, n_sensors))}
        arrays = {name: _readonly(np.concatenate(p) if p else empty[name]) for name, p in pieces.items()}
        t = self.tally
        return {
            "n_instances": self.n_done,
            "candidate_indices": arrays["candidates"],
            "per_sensor_falsified": None if t is None else _readonly(np.array(t["per_sensor_falsified"], np.int64)),
            "falsified_only_by": None if t is None else _readonly(np.array(t["falsified_only_by"], np.int64)),
            "n_invalid": None if t is None else int(t["n_invalid"]),
            "n_violated": arrays.get("n_violated"),
            "candidate_parameters": arrays.get("parameters"),
            "candidate_predictions": arrays.get("predictions"),
        }

    def _load(self, k: int, name: str) -> np.ndarray:
        path = self.part_path(k, name)
        try:
            return np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError) as exc:
            raise ValueError(f"checkpoint: cannot read {path} ({exc}); delete the folder to start over") from None

    # -- writing -----------------------------------------------------------

    def due(self) -> bool:
        return time.monotonic() - self._last >= self.every

    def flush(self, acc, tail: tuple[int, np.ndarray] | None = None,
              arrays: dict[str, list[np.ndarray]] | None = None, final: bool = False) -> None:
        """Saves what ``acc`` (a ``_core.Falsifier`` started at instance
        ``base``) found since the last flush. ``tail`` is (index, row) of the
        last instance falsified; ``arrays`` the lists of candidate rows since
        the last flush (emptied here once written)."""
        if self.broken:
            raise RuntimeError("checkpoint: an earlier write failed; the run cannot go on")
        n_done = self.base + int(acc.n_instances)
        if n_done == self.n_done and not final:
            return
        with deferred_sigint():
            try:
                self._write(acc, n_done, tail, arrays or {}, final)
            except BaseException:
                self.broken = True
                raise

    def _write(self, acc, n_done: int, tail, arrays: dict, final: bool) -> None:
        files: dict[str, np.ndarray] = {}
        parts = list(self.parts)
        if n_done > self.n_done:
            files["candidates"] = acc.candidates(self._seen).astype(np.int64) + self.base
            if "n_violated" in self.fields:
                files["n_violated"] = acc.take_violations().view(np.int32)
            for name, rows in arrays.items():
                files[name] = np.concatenate(rows)
            parts.append({"n_instances": n_done - self.n_done, "n_candidates": len(files["candidates"])})
        tally = acc.tally()
        if tally is not None:
            base = self._base_tally or {"per_sensor_falsified": 0, "falsified_only_by": 0, "n_invalid": 0}
            tally = {
                "per_sensor_falsified": (np.asarray(base["per_sensor_falsified"], np.int64)
                                         + tally[0].astype(np.int64)).tolist(),
                "falsified_only_by": (np.asarray(base["falsified_only_by"], np.int64)
                                      + tally[1].astype(np.int64)).tolist(),
                "n_invalid": int(base["n_invalid"]) + int(tally[2]),
            }
        last_row = digest(tail[1]) if tail is not None and tail[0] == n_done - 1 else None
        state = {"format": FORMAT, "fingerprint": self.fingerprint, "n_done": n_done, "complete": final,
                 "first_row": self.first_row, "last_row": last_row, "tally": tally, "extra": self.extra,
                 "parts": parts}
        target, written = None, []
        try:
            for name, arr in files.items():
                target = self.part_path(len(self.parts), name)
                save_npy(target, arr)
                written.append(target)
            target = self.folder / STATE
            save_state(target, json.dumps(state, indent=1))
        except OSError as exc:
            for path in written:  # not listed in the state: only holding space the retry needs
                with contextlib.suppress(OSError):
                    path.unlink()
            raise CheckpointError(
                exc.errno,
                f"checkpoint: could not write {target.name} in {self.folder} ({exc.strerror or exc}). "
                f"The folder still holds the state after instance {self.n_done:,}: run the same call "
                "again to resume from there once the problem is fixed",
            ) from exc
        for rows in arrays.values():
            rows.clear()
        self._seen += len(files.get("candidates", ()))
        self.n_done, self.parts, self.tally, self.last_row, self.complete = n_done, parts, tally, last_row, final
        self._last = time.monotonic()
        if final:
            self._tidy()

    def _tidy(self) -> None:
        """Removes the parts and temporary files interrupted sessions left;
        only names this class writes, so other files in the folder are kept."""
        for name in ("candidates",) + self.fields:
            for path in self.folder.glob(f"part-??????.{name}.npy"):
                if path.name[5:11].isdigit() and int(path.name[5:11]) >= len(self.parts):
                    path.unlink(missing_ok=True)
        # atomic.atomic_path's temporary names: ".<target>.<pid>.<uuid>.tmp"
        for pattern in (".part-??????.*.npy.*.tmp", f".{STATE}.*.tmp"):
            for path in self.folder.glob(pattern):
                path.unlink(missing_ok=True)


def _check_state(state: dict) -> None:
    """Raises ValueError unless ``state`` has the shape ``_write`` gives it."""
    def count(v) -> bool:
        return isinstance(v, int) and not isinstance(v, bool) and v >= 0

    ok = (isinstance(state.get("fingerprint"), dict) and count(state.get("n_done"))
          and isinstance(state.get("complete"), bool) and isinstance(state.get("extra", {}), dict)
          and all(isinstance(state.get(k), (str, type(None))) for k in ("first_row", "last_row"))
          and isinstance(state.get("parts"), list)
          and all(isinstance(p, dict) and count(p.get("n_instances")) and count(p.get("n_candidates"))
                  for p in state["parts"]))
    tally = state.get("tally")
    if ok and tally is not None:
        n_sensors = state["fingerprint"].get("n_sensors")
        ok = (isinstance(tally, dict) and count(tally.get("n_invalid"))
              and all(isinstance(tally.get(k), list) and len(tally[k]) == n_sensors and all(map(count, tally[k]))
                      for k in ("per_sensor_falsified", "falsified_only_by")))
    if not ok:
        raise ValueError("damaged: a field is missing or has the wrong type or length")


def every_seconds(value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not value >= 0:
        raise ValueError(f"checkpoint_every: expected a number of seconds >= 0, got {value!r}")
    return float(value)


def save_on_error(ckpt: Checkpoint | None, acc, tail, exc: BaseException, arrays=None) -> None:
    """Keeps the work done before an error or Ctrl-C (the chunk that failed
    left no trace in ``acc``), unless the checkpoint itself failed."""
    if ckpt is None or ckpt.broken or isinstance(exc, CheckpointError):
        return
    try:
        ckpt.flush(acc, tail, arrays)
    except BaseException as again:  # the original error matters more
        exc.add_note(f"edmf_rs: the last checkpoint could not be saved either: {again}")


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr.flags.writeable = False
    return arr
