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
accidental change of the input, see ``rust/src/digest.rs``).

Every state names the part files of the next save (``pending``): the only
ones a crash during that save can leave that it does not list. Before the
first save writes any part, a state with nothing done (``n_done`` 0, no
parts) is written to name them, so a folder without a state holds nothing a
crash left (its ``.lock`` says nothing about its files). A run overwrites or
removes no part file but those the state it found names as pending and
those it writes itself: any other file named like a part (the user's, or
another run's) is never touched, the run stops first, naming it. A state
with nothing done is no run to resume: any call starts over in its folder,
as in an empty one (deleting the folder starts over too).
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
from .folder_lock import FolderLock, folder_path

STATE = state_file.STATE
FORMAT = state_file.FORMAT
#: Fingerprint entries that are content hashes (not worth printing).
HASHED = ("measurements", "thresholds", "model")
#: Largest share of a run's time its periodic saves take (even with ``checkpoint_every=0``: a state lists every
#: part, so N saves after N tiny chunks would cost O(N^2)), by waiting (1 / share - 1) times the last save's time.
MAX_SAVE_SHARE = 0.05
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


def _nothing_done(state: dict) -> bool:
    """A state written before a run's first save (`Checkpoint._claim_first`):
    no run to resume, but its pending files are a run's."""
    return state.get("n_done") == 0 and state.get("parts") == [] and state.get("complete") is False


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
        self._lock = FolderLock(self.folder)
        try:
            self._read_progress()
            if not self.complete:  # before any work: the first save's names
                self._refuse_foreign(self._names(len(self.parts)))
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
        self._pending: list[str] = state["pending"] if state is not None else []
        # Part files this run may overwrite or remove: those a crash during the
        # state's next save can leave (none without a state), and its own.
        self._claimable = set(self._pending)
        state = {} if state is None or _nothing_done(state) else state  # nothing done: start over
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
        self._last, self._cost = time.monotonic(), 0.0
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
        if isinstance(state.get("fingerprint"), dict) and not _nothing_done(state):  # other inputs: say which first
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
        wait = self._cost * (1.0 / MAX_SAVE_SHARE - 1.0)
        return time.monotonic() - self._last >= max(self.every, wait)

    def flush(self, acc, arrays: dict[str, list[np.ndarray]] | None = None, final: bool = False) -> None:
        """Saves what ``acc`` (a ``_core.Falsifier`` started at instance
        ``base``) found since the last flush; ``arrays`` the lists of
        candidate rows since the last flush (emptied here once written)."""
        if self.broken:
            raise RuntimeError("checkpoint: an earlier write failed; the run cannot go on")
        n_done = self.base + int(acc.n_instances)
        if n_done == self.n_done and not final:
            return
        start = time.monotonic()
        with deferred_sigint():
            try:
                self._write(acc, n_done, arrays or {}, final)
                self._cost = self._last - start
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
        had_state, target, written, sums = self._had_state, self.folder / STATE, [], {}
        try:
            if files and not self.parts and set(self._pending) != set(self._names(0)):
                self._claim_first()  # no state names them yet (none, or one of a call with other fields)
            for name, arr in files.items():
                target = self.folder / parts.name(len(self.parts), name)
                self._claimable.add(target.name)
                sums[name] = save_npy(target, arr)
                written.append(target)
            if files:
                new_parts.append({"n_instances": n_done - self.n_done, "n_candidates": n_candidates,
                                  "candidates": form, "sha256": sums})
            state = self._state(n_done, final, tally, new_parts)
            target = self.folder / STATE
            save_state(target, state)
        except OSError as exc:
            self._undo(written, had_state)
            before = (f"The folder still holds the state after instance {self.n_done:,}: run the same call again "
                      "to resume from there" if had_state else "Nothing was saved: run the same call again")
            raise CheckpointError(exc.errno, f"checkpoint: could not write {target.name} in {self.folder} "
                                  f"({exc.strerror or exc}). {before} once the problem is fixed") from exc
        for rows in arrays.values():
            rows.clear()
        self.n_done, self.parts, self.tally, self.complete = n_done, new_parts, tally, final
        self.was_rereadable = state["rereadable"]
        self._saved(state)
        self._last = time.monotonic()
        if final:
            self._tidy()

    def _names(self, k: int) -> list[str]:
        """The part files of save ``k``."""
        return [parts.name(k, name) for name in ("candidates",) + self.fields]

    def _state(self, n_done: int, final: bool, tally: dict | None, new_parts: list[dict]) -> dict:
        """The state after ``n_done`` instances: those recorded, or none (the
        first save's claim, made once its instances are recorded)."""
        rows = {"blocks": self.rows.blocks(), "partial": self.rows.partial()} if n_done else {
            "blocks": [], "partial": None}
        return {"format": FORMAT, "fingerprint": self.fingerprint, "n_done": n_done, "complete": final,
                "rereadable": self.rereadable and self.was_rereadable,
                "rows": {"checksum": _core.RowDigest.algorithm, "block_rows": _core.RowDigest.block_rows, **rows},
                "tally": tally, "extra": self.extra, "parts": new_parts,
                # The next save's part files: all a crash can leave that the parts do not list.
                "pending": self._names(len(new_parts))}

    def _saved(self, state: dict) -> None:
        """``state`` is the one in the folder now: the next save checks it is still there."""
        self._had_state, self._saved_id = True, state_file.identity(self.folder / STATE)
        self._pending = state["pending"]

    def _claim_first(self) -> None:
        """Before the first save writes any part: a state with nothing done
        naming them as pending, so that a crash while they are written leaves
        only files a state claims (with no state, none is claimed, and a
        user's file named like a part is never overwritten). The files an
        earlier such state named that this run does not write (a call with
        other fields) are removed first: nothing would claim them after."""
        pending = self._names(0)
        for name in set(self._pending) - set(pending):
            (self.folder / name).unlink(missing_ok=True)
            self._claimable.discard(name)
        state = self._state(0, False, None, [])  # its extra and rereadable are not read back
        save_state(self.folder / STATE, state)
        self._saved(state)

    def _undo(self, written: list, had_state: bool) -> None:
        """After a failed save: removes the parts it wrote (no state lists them:
        they only hold space the retry needs) and then, if there was no state
        before, the state with nothing done it wrote, so the folder is as it
        was. Kept if a part could not be removed: it claims that part."""
        for path in written:
            with contextlib.suppress(OSError):
                path.unlink()
        if self._had_state and not had_state and not any(os.path.lexists(path) for path in written):
            with contextlib.suppress(OSError):
                (self.folder / STATE).unlink()

    def _tidy(self) -> None:
        """Removes what interrupted sessions may have left, and only files a
        run wrote: the part files the state found named as pending that are
        not parts of the run (of a save that never completed), and the
        temporary files of the state's and the parts' atomic writes
        (``.<name>.<pid>.<32 hex>.tmp``, see :mod:`.atomic`)."""
        listed = {STATE} | {name for k in range(len(self.parts) + 1) for name in self._names(k)}
        for name in self._claimable - {name for k in range(len(self.parts)) for name in self._names(k)}:
            (self.folder / name).unlink(missing_ok=True)  # others are not a run's: kept
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
