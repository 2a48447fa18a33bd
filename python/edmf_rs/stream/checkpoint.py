"""Resumable runs: a folder holding what a long run has found so far.

The folder holds ``state.json`` (the position reached, the counts so far, a
fingerprint of the inputs, a checksum of every block of instances done and the
sha256 of every part, itself checksummed: see :mod:`.state`), the candidates
as ``.npy`` parts, one set per save (see :mod:`.parts`), and the ``.lock``
file (see :mod:`.folder_lock`). Parts are written first and the state
replaced last, each atomically, so after a crash, SIGKILL, Ctrl-C or full
disk the folder always describes a consistent prefix of the run, and running
the same call again continues from its end, after re-reading the instances
done and checking every one of them against their checksums (a guard against
accidental change of the input, see ``rust/src/digest.rs``). A file named
like a part that no run wrote there (the user's, or another run's) is never
overwritten or removed: the run stops first, naming it.
"""

from __future__ import annotations

import contextlib
import errno
import numbers
import os
import re
import time

import numpy as np

from .. import _core
from . import chunks, parts
from . import state as state_file
from .atomic import deferred_sigint
from .chunks import digestible
from .folder_lock import LOCK, FolderLock, folder_path

STATE = state_file.STATE
FORMAT = state_file.FORMAT
#: Fingerprint entries that are content hashes (not worth printing).
HASHED = ("measurements", "thresholds", "model")
#: Writers (module-level so tests can make them fail like a full disk).
save_npy = parts.save
save_state = state_file.write


class CheckpointError(OSError):
    """Writing a checkpoint failed; the folder keeps its previous state.

    Raised by `falsify` and `falsify_model` with ``checkpoint=`` when a save
    fails (a full disk, a folder made read-only during the run), or finds the
    folder removed or emptied. Running the same call again once the problem is
    fixed resumes from the last state saved (or starts over, if it is gone).
    An ``OSError``, so ``except OSError`` catches it too.

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


class Checkpoint:
    """A run's folder: reads the saved state, checks it belongs to this call,
    and appends the progress of the current accumulator.

    ``fields`` names the per-candidate or per-instance arrays saved besides
    the candidate indices (``n_violated``, ``parameters``, ``predictions``);
    ``rereadable`` whether the input can be read again (not an iterator).
    """

    def __init__(self, folder, fp: dict, every: float, fields: tuple[str, ...] = (),
                 input_name: str = "predictions", rereadable: bool = True):
        # Absolute: a model that changes the working directory must not move the folder under the run
        self.folder = folder_path(folder).absolute()
        if self.folder.exists() and not self.folder.is_dir():
            raise ValueError(f"checkpoint: expected a folder, {self.folder} is a file")
        self.every, self.fields, self.input_name = float(every), fields, input_name
        self.fingerprint, self.rereadable = fp, rereadable
        # Without it no run has been here, so no crash can have left a first save's parts.
        self._visited = os.path.lexists(self.folder / LOCK)
        self._lock = FolderLock(self.folder)
        try:
            self._read_progress()
            if not self.complete:  # before any work: the first save's names
                self._refuse_foreign(parts.name(len(self.parts), name) for name in ("candidates",) + fields)
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
        self._had_state = state is not None
        self._saved_id = state_file.identity(self.folder / STATE)
        state = state or {}
        self._pending: list[str] = state.get("pending", [])
        # Part files this run may overwrite or remove: the ones a crash during
        # a save can leave (the state's next names; with no state, the first
        # save's where a run has locked the folder before), and its own.
        self._claimable = set(self._pending) if self._had_state else {
            parts.name(0, name) for name in ("candidates",) + self.fields} if self._visited else set()
        self.n_done: int = state.get("n_done", 0)
        self.parts: list[dict] = state.get("parts", [])
        self.tally: dict | None = state.get("tally")
        self.complete: bool = state.get("complete", False)
        self.extra: dict = state.get("extra", {})
        self.was_rereadable: bool = state.get("rereadable", True)
        rows = state.get("rows", {})
        self.saved_blocks: list[str] = rows.get("blocks", [])
        self.saved_partial: str | None = rows.get("partial")
        self.rows = _core.RowDigest()  # fed every instance from 0: those done again on resumption
        # Instances and tally before this session's accumulator started.
        self.base, self._base_tally = self.n_done, self.tally
        self._last = time.monotonic()
        self.broken = False

    def _refuse_foreign(self, names, error=ValueError) -> None:
        """Refuses to overwrite or remove a file named like a part that no run
        saving in this folder wrote: another run's, or the user's (``names``:
        the part files about to be written)."""
        for name in names:
            if name not in self._claimable and os.path.lexists(self.folder / name):
                message = (f"checkpoint: {self.folder} holds {name}, which is no part of the run saved there "
                           "(another run's file, or a user's) and which this run would overwrite: move it "
                           "away, then run the same call again (or give another folder)")
                raise error(errno.EEXIST, message) if error is CheckpointError else error(message)

    # -- reading -----------------------------------------------------------

    def _read_state(self) -> dict | None:
        path = self.folder / STATE
        state = state_file.read(path)
        if state is None:
            return None
        if isinstance(state.get("fingerprint"), dict):  # other inputs: say which before anything else
            self._check(state["fingerprint"])
            for key, value in self.fingerprint.items():
                if isinstance(value, dict) and "unhashable" in value:
                    raise ValueError(
                        f"checkpoint: {self.folder} holds a run, but this call's {key} cannot be fingerprinted "
                        f"({value['unhashable']}), so whether it is the one the run was made with cannot be "
                        f"checked; give the {key} a __edmf_fingerprint__() method returning what identifies "
                        "it (JSON data), or pass another folder (or delete this one) to start over"
                    )
        try:
            state_file.check_shape(state, self.fields)
            rows = state["rows"]
            if (rows["block_rows"], rows.get("checksum")) != (_core.RowDigest.block_rows, _core.RowDigest.algorithm):
                raise ValueError(f"checksums {rows.get('checksum')!r} of {rows['block_rows']}-instance blocks, "
                                 f"this version uses {_core.RowDigest.algorithm!r} of {_core.RowDigest.block_rows}")
        except ValueError as exc:
            raise ValueError(f"checkpoint: {path} is not an edmf_rs checkpoint state ({exc}); "
                             "pass another folder, or delete this one to start over") from None
        return state

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

    def verify_skipped(self, first: int, rows: np.ndarray) -> None:
        """Checks rows already done (``first ..``, fed in order from instance
        0) against the saved digests; refuses the first block that differs."""
        if first != self.rows.n_rows:
            raise RuntimeError(f"checkpoint: rows from instance {first} given after {self.rows.n_rows}")
        n_before = self.rows.n_blocks
        self.rows.update(digestible(rows))
        for k, got in enumerate(self.rows.blocks(n_before), start=n_before):
            if k >= len(self.saved_blocks) or got != self.saved_blocks[k]:
                self._changed(k)
        if self.rows.n_rows == self.n_done and self.rows.partial() != self.saved_partial:
            self._changed(self.n_done // _core.RowDigest.block_rows)

    def _changed(self, block: int):
        size = _core.RowDigest.block_rows
        first, last = block * size, min((block + 1) * size, self.n_done) - 1
        raise ValueError(
            f"checkpoint: the {self.input_name} differ from the run saved in {self.folder} in instances "
            f"{first}..{last} (block {block}, the first that differs): the input changed since; pass the "
            "same input to resume, or another folder (or delete this one) to start over"
        )

    def check_verified(self) -> None:
        """Every instance done before this session was re-read and checked."""
        if self.rows.n_rows < self.n_done:
            raise ValueError(
                f"checkpoint: the {self.input_name} ended after {self.rows.n_rows} instances, but the run "
                f"saved in {self.folder} had already done {self.n_done}: it is not the input the run began "
                "with; pass the same input, or another folder to start over"
            )

    def record(self, first: int, rows: np.ndarray) -> None:
        """Instances ``first ..`` (``rows``) were done in this session."""
        self.digest_from(first).update(digestible(rows))

    def digest_from(self, first: int):
        """The digest (fed every instance before ``first``) that instances
        ``first ..``, done in this session, are fed to next."""
        if first != self.rows.n_rows:
            self.check_verified()
            raise RuntimeError(f"checkpoint: rows from instance {first} given after {self.rows.n_rows}")
        return self.rows

    def confirm_finished(self, remaining) -> None:
        """Before a finished run's saved result is returned: ``remaining`` is the
        input from instance ``n_done`` on (its skipped rows pass
        `verify_skipped`); any row left means the input is not the one the run
        finished."""
        try:
            for block in remaining:
                if len(block):
                    raise ValueError(
                        f"checkpoint: {self.folder} holds a finished run over {self.n_done} instances, but the "
                        f"{self.input_name} have more; pass the same input, or another folder to start over"
                    )
        finally:
            chunks.close(remaining)
        self.check_verified()

    def refuse_unchecked(self) -> None:
        """A finished run cannot be checked against a one-pass iterable without drawing it all again."""
        raise ValueError(
            f"checkpoint: {self.folder} holds a finished run, and the {self.input_name} are a one-pass "
            "iterator (e.g. a generator) that would have to be drawn again in full to check it is the "
            "input the run was made from. Pass trust_iterable=True to get the saved result without that "
            "check, or pass the input as an array, a .npy file or a list of chunks to have every instance "
            "checked"
        )

    def saved(self, n_sensors: int) -> dict[str, object]:
        """The finished run read back from the parts (each checked against
        its checksum, dtype, shape and range), as the keyword arguments of a
        ``FalsificationResult`` (without thresholds and measurements), but for
        ``candidate_segments``: the candidates, part by part, as
        ``CandidateSegments`` takes them (bitmap parts stay bitmaps)."""
        segments, arrays = parts.read_run(self.folder, self.parts, self.fields, n_sensors,
                                          self.extra.get("n_parameters"))
        arrays = {name: _readonly(arr) for name, arr in arrays.items()}
        t = self.tally
        return {
            "n_instances": self.n_done,
            "candidate_segments": segments,
            "per_sensor_falsified": None if t is None else _readonly(np.array(t["per_sensor_falsified"], np.int64)),
            "falsified_only_by": None if t is None else _readonly(np.array(t["falsified_only_by"], np.int64)),
            "n_invalid": None if t is None else int(t["n_invalid"]),
            "n_violated": arrays.get("n_violated"),
            "candidate_parameters": arrays.get("parameters"),
            "candidate_predictions": arrays.get("predictions"),
        }

    # -- writing -----------------------------------------------------------

    def due(self) -> bool:
        return time.monotonic() - self._last >= self.every

    def flush(self, acc, arrays: dict[str, list[np.ndarray]] | None = None, final: bool = False) -> None:
        """Saves what ``acc`` (a ``_core.Falsifier`` started at instance
        ``base``) found since the last flush; ``arrays`` the lists of
        candidate rows since the last flush (emptied here once written)."""
        if self.broken:
            raise RuntimeError("checkpoint: an earlier write failed; the run cannot go on")
        n_done = self.base + int(acc.n_instances)
        if n_done == self.n_done and not final:
            return
        with deferred_sigint():
            try:
                self._write(acc, n_done, arrays or {}, final)
            except BaseException:
                self.broken = True
                raise

    def _write(self, acc, n_done: int, arrays: dict, final: bool) -> None:
        self.check_verified()
        # Removed, emptied or replaced: a save would recreate it, and the run fail reading the parts back at the end
        changed = self._had_state and state_file.identity(self.folder / STATE) != self._saved_id
        if changed or not self.folder.is_dir():
            raise CheckpointError(errno.ENOENT, f"checkpoint: folder {self.folder} was removed, emptied or changed "
                                  f"during the run, which had saved {self.n_done:,} instances there; run the same "
                                  "call again to resume from what the folder holds (or start over if it is empty)")
        if self.rows.n_rows != n_done:
            raise RuntimeError(f"checkpoint: {n_done} instances done but {self.rows.n_rows} recorded")
        files: dict[str, np.ndarray] = {}
        new_parts = list(self.parts)
        if n_done > self.n_done:
            # The accumulator's candidates since the last save (each save takes them out; it started at `base`).
            form, n_candidates, files["candidates"] = parts.candidates_file(
                acc, self.n_done, n_done - self.n_done, self.base)
            if "n_violated" in self.fields:
                files["n_violated"] = acc.take_violations().view(np.int32)
            for name, rows in arrays.items():
                files[name] = np.concatenate(rows)
        tally = state_file.add_tally(self._base_tally, acc.tally())
        self._refuse_foreign((parts.name(len(self.parts), name) for name in files), CheckpointError)
        target, written, sums = None, [], {}
        try:
            for name, arr in files.items():
                target = self.folder / parts.name(len(self.parts), name)
                self._claimable.add(target.name)
                sums[name] = save_npy(target, arr)
                written.append(target)
            if files:
                new_parts.append({"n_instances": n_done - self.n_done, "n_candidates": n_candidates,
                                  "candidates": form, "sha256": sums})
            state = {"format": FORMAT, "fingerprint": self.fingerprint, "n_done": n_done, "complete": final,
                     "rereadable": self.rereadable and self.was_rereadable,
                     "rows": {"checksum": _core.RowDigest.algorithm, "block_rows": _core.RowDigest.block_rows,
                              "blocks": self.rows.blocks(),
                              "partial": self.rows.partial()},
                     "tally": tally, "extra": self.extra, "parts": new_parts,
                     # The next save's part files: all a crash can leave that the parts do not list.
                     "pending": [parts.name(len(new_parts), name) for name in ("candidates",) + self.fields]}
            target = self.folder / STATE
            save_state(target, state)
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
        self.n_done, self.parts, self.tally, self.complete = n_done, new_parts, tally, final
        self.was_rereadable, self._had_state = state["rereadable"], True
        self._saved_id = state_file.identity(self.folder / STATE)
        self._pending = state["pending"]
        self._last = time.monotonic()
        if final:
            self._tidy()

    def _tidy(self) -> None:
        """Removes what interrupted sessions may have left, and only what the
        state lists: the pending part files of a save that never completed,
        and the temporary files of the state's and the parts' atomic writes
        (``.<name>.<pid>.<32 hex>.tmp``, see :mod:`.atomic`)."""
        listed = {STATE} | {parts.name(k, name) for k in range(len(self.parts) + 1)
                            for name in ("candidates",) + self.fields}
        for name in self._pending:
            if name in self._claimable:  # else not left by a run: kept
                (self.folder / name).unlink(missing_ok=True)
        temporary = re.compile(r"\.(?P<name>.+)\.[0-9]+\.[0-9a-f]{32}\.tmp")
        for path in self.folder.iterdir():
            m = temporary.fullmatch(path.name)
            if m and m["name"] in listed and not path.is_symlink() and path.is_file():
                path.unlink(missing_ok=True)


def every_seconds(value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not value >= 0:
        raise ValueError(f"checkpoint_every: expected a number of seconds >= 0, got {value!r}")
    return float(value)


def save_on_error(ckpt: Checkpoint | None, acc, exc: BaseException, arrays=None) -> None:
    """Keeps the work done before an error or Ctrl-C (the chunk that failed
    left no trace in ``acc``), unless the checkpoint itself failed or the
    interruption fell between a chunk's falsification and its digest (then
    the work since the last save is redone on resumption)."""
    if ckpt is None or ckpt.broken or isinstance(exc, CheckpointError):
        return
    if ckpt.rows.n_rows != ckpt.base + int(acc.n_instances):
        return
    try:
        ckpt.flush(acc, arrays)
    except BaseException as again:  # the original error matters more
        exc.add_note(f"edmf_rs: the last checkpoint could not be saved either: {again}")


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr.flags.writeable = False
    return arr
