"""A checkpoint's part files: one ``.npy`` per field per save, written with
its sha256 (kept in the state) and read back only when the bytes match and
the array has the dtype, shape and range a run writes."""

from __future__ import annotations

import hashlib
import io
import os
import stat
from pathlib import Path

import numpy as np

from . import atomic
from .state import STATE

#: How a part stores its candidates: ``indices`` (int64, one per candidate)
#: or ``bitmap`` (uint64 words, bit ``i % 64`` of word ``i // 64`` set iff
#: the part's instance ``i`` is a candidate), whichever is smaller: with every
#: instance a candidate the bitmap is 64 times smaller than the indices, and
#: writing, hashing and checking 8 bytes per candidate cost several times the
#: falsification itself.
FORMS = {"indices": np.dtype(np.int64), "bitmap": np.dtype("<u8")}


#: What each field holds: allowed dtypes, and whether rows are instances
#: (``n_violated``) or candidates (the others).
DTYPES = {
    "candidates": tuple(FORMS.values()),
    "n_violated": (np.dtype(np.int32),),
    "parameters": (np.dtype(np.float64),),
    "predictions": (np.dtype(np.float64), np.dtype(np.float32)),
}


def name(k: int, field: str) -> str:
    return f"part-{k:06d}.{field}.npy"


def save(target: Path, array: np.ndarray) -> str:
    """Writes ``array`` atomically; returns the sha256 of the bytes written."""
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.asarray(array), allow_pickle=False)
    data = buf.getvalue()
    atomic.write_bytes(target, data)
    return hashlib.sha256(data).hexdigest()


def load(path: Path, sha256: str, field: str, rows: int, width: int | None = None,
         dtype: np.dtype | None = None) -> np.ndarray:
    """The array in ``path``, refused (ValueError naming it) unless its bytes
    have the recorded sha256 and it is ``rows`` long of the field's dtype
    (``dtype`` if given; ``width`` columns for 2-D fields)."""
    def damaged(why: str) -> ValueError:
        return ValueError(f"checkpoint: {path} {why}; the folder was changed since the run wrote it: "
                          "delete the folder to start over")

    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise damaged("is not a regular file")
        with open(path, "rb") as fh:
            data = fh.read()
    except OSError as exc:
        raise damaged(f"cannot be read ({exc.strerror or exc})") from None
    if hashlib.sha256(data).hexdigest() != sha256:
        raise damaged("does not have the checksum recorded in the state (damaged, or from another run)")
    try:
        arr = np.load(io.BytesIO(data), allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        raise damaged(f"is not a readable .npy file ({exc})") from None
    ndim = 1 if field in ("candidates", "n_violated") else 2
    allowed = DTYPES[field] if dtype is None else (dtype,)
    if arr.dtype not in allowed or arr.ndim != ndim:
        raise damaged(f"holds a {arr.ndim}-D {arr.dtype} array, expected {ndim}-D {allowed[0]}")
    if arr.shape[0] != rows or (ndim == 2 and width is not None and arr.shape[1] != width):
        raise damaged(f"has shape {arr.shape}, expected {rows} rows" + (f" x {width}" if ndim == 2 else ""))
    return arr


def check_candidates(path: Path, idx: np.ndarray, first: int, n_instances: int) -> None:
    """Candidate indices of a part must be increasing instances of that part."""
    if idx.size and (idx[0] < first or idx[-1] >= first + n_instances or np.any(np.diff(idx) <= 0)):
        raise ValueError(f"checkpoint: {path} holds candidate indices outside instances "
                         f"{first}..{first + n_instances - 1} or not increasing; delete the folder to start over")


def check_violations(path: Path, counts: np.ndarray, n_sensors: int, candidates: np.ndarray) -> None:
    """Violated-sensor counts lie in 0..n_sensors and are 0 at every candidate
    (``candidates``: a boolean mask of the part's instances, or their positions)."""
    if counts.size and (counts.min() < 0 or counts.max() > n_sensors) or np.any(counts[candidates] != 0):
        raise ValueError(f"checkpoint: {path} holds counts of violated sensors out of range 0..{n_sensors} "
                         "or inconsistent with the candidates; delete the folder to start over")


def candidates_file(acc, first: int, n_instances: int, offset: int) -> tuple[str, int, np.ndarray]:
    """``(form, count, array)`` of a part's candidates (see `FORMS`): the run's
    instances ``first .. first + n_instances``, the candidates the accumulator
    ``acc`` holds (its instance ``p`` is the run's ``offset + p``), which are
    then taken out of it."""
    count, since = int(acc.n_candidates), first - offset
    if count * 64 <= n_instances:
        out = "indices", count, acc.candidates_since(since).astype(np.int64) + offset
    else:
        out = "bitmap", count, acc.candidate_bitmap(since, n_instances).astype("<u8", copy=False)
    acc.take_candidate_segments()  # saved: the accumulator need not keep them
    return out


def unpack_bits(rows: int, words: np.ndarray) -> np.ndarray:
    """The first ``rows`` bits of little-endian uint64 ``words``, as booleans."""
    raw = np.ascontiguousarray(words, dtype="<u8").view(np.uint8)
    return np.unpackbits(raw, count=rows, bitorder="little").view(bool)


def count_bits(words: np.ndarray) -> int:
    """Set bits of ``words``, without unpacking them (a byte per instance is
    50 MB for 5e7 instances) where NumPy counts bits itself (2.0 and later)."""
    if hasattr(np, "bitwise_count"):
        return int(np.bitwise_count(words).sum(dtype=np.int64))
    return int(np.count_nonzero(unpack_bits(len(words) * 64, words)))


def check_bitmap(path: Path, words: np.ndarray, n_instances: int, n_candidates: int) -> None:
    """Refuses a bitmap part unless exactly ``n_candidates`` bits are set and
    none past ``n_instances`` (``words``: the part's ``ceil(n_instances / 64)``
    words, as `load` checked)."""
    tail = n_instances % 64
    past = bool(tail and words.size and int(words[-1]) >> tail)
    if past or count_bits(words) != n_candidates:
        raise ValueError(f"checkpoint: {path} holds a candidate bitmap with bits past its {n_instances} "
                         f"instances or not {n_candidates} set; delete the folder to start over")


def bitmap_mask(words: np.ndarray, n_instances: int) -> np.ndarray:
    """The candidates of a bitmap part (checked by `check_bitmap`) as a boolean mask."""
    return unpack_bits(n_instances, words)


def read_run(folder: Path, listed: list[dict], fields: tuple[str, ...], n_sensors: int,
             n_parameters: int | None) -> tuple[list, dict[str, np.ndarray]]:
    """A finished run's parts (``listed``: the state's ``parts``), each checked
    against its checksum, dtype, shape and range: the candidates part by part,
    as ``CandidateSegments`` takes them (bitmap parts stay bitmaps, as
    ``(first instance, n_instances, words)``), and each other field's rows."""
    names = ("candidates",) + fields
    pieces: dict[str, list[np.ndarray]] = {field: [] for field in names}
    first = 0
    widths = {"parameters": n_parameters, "predictions": n_sensors}
    for k, part in enumerate(listed):
        n, form = part["n_instances"], part.get("candidates")
        if form not in FORMS:
            raise ValueError(f"checkpoint: {folder / STATE} gives part {k} candidates of form {form!r}, "
                             f"expected one of {sorted(FORMS)}; delete the folder to start over")
        loaded = {}
        for field in names:
            rows = {"n_violated": n, "candidates": -(-n // 64) if form == "bitmap" else part["n_candidates"]}
            loaded[field] = load(folder / name(k, field), part["sha256"][field], field,
                                 rows.get(field, part["n_candidates"]), widths.get(field),
                                 FORMS[form] if field == "candidates" else None)
        path = folder / name(k, "candidates")
        if form == "bitmap":
            words = loaded["candidates"]
            check_bitmap(path, words, n, part["n_candidates"])
            loaded["candidates"] = (first, n, words)
            mask = bitmap_mask(words, n) if "n_violated" in loaded else None  # only to check the counts
        else:
            check_candidates(path, loaded["candidates"], first, n)
            mask = loaded["candidates"] - first  # indexes the part's instances like the bitmap's mask
        if "n_violated" in loaded:
            check_violations(folder / name(k, "n_violated"), loaded["n_violated"], n_sensors, mask)
        for field in names:
            pieces[field].append(loaded[field])
        first += n
    empty = {"n_violated": np.empty(0, np.int32), "parameters": np.empty((0, n_parameters or 0)),
             "predictions": np.empty((0, n_sensors))}
    segments = [c if isinstance(c, tuple) else c.astype(np.uint64) for c in pieces.pop("candidates")]
    return segments, {field: np.concatenate(p) if p else empty[field] for field, p in pieces.items()}
