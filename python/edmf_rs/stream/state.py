"""A checkpoint's ``state.json``: written with a checksum of its own content,
read back only when it is whole, unedited and of the expected shape.

Anything else (a damaged or hand-edited file, one nested or numbered beyond
what JSON readers handle, a FIFO in its place) is a ``ValueError`` naming
the file, never a raw ``OverflowError``/``RecursionError`` or a hang.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
from pathlib import Path

import numpy as np

from . import atomic

STATE = "state.json"
#: Version 4: a part's candidates are a bitmap where that is smaller than
#: their indices (``parts.FORMS``). Version 3 checked rows with the same
#: block checksum ``fletcher64x8/1`` (``rust/src/digest.rs``) but stored
#: indices only; version 2 recorded xxh3 digests. A state names its block
#: checksum (``rows.checksum``): one of ``fletcher64x8/1`` (float32 widened
#: to float64) is refused by name.
FORMAT = "edmf_rs.checkpoint/4"
#: Formats of earlier versions, refused with a message saying so.
EARLIER = {"edmf_rs.checkpoint/2": "xxh3 digests of its rows",
           "edmf_rs.checkpoint/3": "candidates stored as indices only"}
#: Largest integer a state may hold (counts are int64 in the results).
INT_MAX = 2**63 - 1
#: A state this large is not one a run wrote (it holds counts and digests).
MAX_BYTES = 64 * 2**20


def identity(path: Path) -> tuple[int, int] | None:
    """Size and modification time of the state file (None if absent): a run
    compares them before each save with what its last save left, to find its
    folder removed, emptied, replaced or restored from a copy meanwhile. Not
    the inode: some network file systems make inode numbers up anew."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_size, st.st_mtime_ns


def _canonical(state: dict) -> bytes:
    body = {k: v for k, v in state.items() if k != "checksum"}
    return json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False).encode("utf-8")


def write(path: Path, state: dict) -> None:
    """Writes ``state`` atomically, with ``checksum``: sha256 of its canonical JSON."""
    state = dict(state, checksum=hashlib.sha256(_canonical(state)).hexdigest())
    atomic.write_text(path, json.dumps(state, indent=1, allow_nan=False))


def read(path: Path) -> dict | None:
    """The state in ``path`` (None when there is none), checked against its checksum."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise ValueError("not a regular file")
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise _damaged(path, exc.strerror or exc) from None
    except ValueError as exc:
        raise _damaged(path, exc) from None
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_BYTES + 1)
        if len(data) > MAX_BYTES:
            raise ValueError(f"larger than {MAX_BYTES} bytes")
        state = json.loads(data.decode("utf-8"), parse_constant=_no_constant)
        if not isinstance(state, dict):
            raise ValueError("not a JSON object")
        if state.get("format") in EARLIER:
            raise _Earlier(state["format"])
        if state.get("format") != FORMAT:
            raise ValueError(f"unknown format {state.get('format')!r}")
        if state.get("checksum") != hashlib.sha256(_canonical(state)).hexdigest():
            raise ValueError("its checksum does not match its content: edited by hand or damaged")
        _check_ints(state, depth=0)
        return state
    except _Earlier as exc:
        fmt = exc.args[0]
        raise ValueError(
            f"checkpoint: {path} was written by an earlier version of edmf_rs (format {fmt!r}, with "
            f"{EARLIER[fmt]}); this version writes format {FORMAT!r} and cannot resume it: delete the "
            "folder or pass another one to start over"
        ) from None
    except OSError as exc:
        raise _damaged(path, exc.strerror or exc) from None
    except (ValueError, TypeError, AttributeError, UnicodeDecodeError, OverflowError, RecursionError) as exc:
        raise _damaged(path, f"{type(exc).__name__}: {exc}" if isinstance(exc, RecursionError) else exc) from None


class _Earlier(ValueError):
    """A state of an earlier format (args: the format)."""


def _damaged(path: Path, why) -> ValueError:
    return ValueError(f"checkpoint: {path} is not an edmf_rs checkpoint state ({why}); "
                      "pass another folder, or delete this one to start over")


def _no_constant(name: str):
    raise ValueError(f"{name} is not a valid value")


def _check_ints(value, depth: int) -> None:
    """Every integer within int64 (else OverflowError deep in NumPy later)."""
    if depth > 8:
        raise ValueError("nested deeper than a checkpoint state")
    if isinstance(value, bool):
        return
    if isinstance(value, int) and not -INT_MAX - 1 <= value <= INT_MAX:
        raise ValueError(f"integer {value} out of the int64 range")
    if isinstance(value, float) and value != value:
        raise ValueError("NaN where a number was expected")
    items = value.values() if isinstance(value, dict) else value if isinstance(value, list) else ()
    for item in items:
        _check_ints(item, depth + 1)


def count(v) -> bool:
    """A non-negative int64 (not a bool, not a float)."""
    return isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= INT_MAX


def add_tally(base: dict | None, counts) -> dict | None:
    """A state's ``tally``: the counts saved before a session (``base``, None
    for none) plus those of its accumulator (``counts``: ``Falsifier.tally()``,
    None without diagnostics)."""
    if counts is None:
        return None
    base = base or {"per_sensor_falsified": 0, "falsified_only_by": 0, "n_invalid": 0}
    return {
        "per_sensor_falsified": (np.asarray(base["per_sensor_falsified"], np.int64)
                                 + counts[0].astype(np.int64)).tolist(),
        "falsified_only_by": (np.asarray(base["falsified_only_by"], np.int64) + counts[1].astype(np.int64)).tolist(),
        "n_invalid": int(base["n_invalid"]) + int(counts[2]),
    }


def check_shape(state: dict, fields: tuple[str, ...]) -> None:
    """Raises ValueError unless ``state`` has the fields, types and lengths a run writes."""
    def hexes(v, n) -> bool:
        return isinstance(v, str) and len(v) == n and all(c in "0123456789abcdef" for c in v)

    rows = state.get("rows")
    ok = (isinstance(state.get("fingerprint"), dict) and count(state.get("n_done"))
          and isinstance(state.get("complete"), bool) and isinstance(state.get("extra", {}), dict)
          and isinstance(state.get("rereadable"), bool)
          and isinstance(rows, dict) and count(rows.get("block_rows")) and rows["block_rows"] > 0
          and isinstance(rows.get("blocks"), list) and all(hexes(b, 32) for b in rows["blocks"])
          and (rows.get("partial") is None or hexes(rows["partial"], 32))
          and isinstance(state.get("pending"), list) and all(isinstance(n, str) for n in state["pending"])
          and isinstance(state.get("parts"), list)
          and all(isinstance(p, dict) and count(p.get("n_instances")) and count(p.get("n_candidates"))
                  and isinstance(p.get("sha256"), dict) and set(p["sha256"]) == {"candidates", *fields}
                  and all(hexes(h, 64) for h in p["sha256"].values())
                  for p in state["parts"]))
    if ok:  # the digests cover exactly the instances done
        n_done, b = state["n_done"], rows["block_rows"]
        ok = len(rows["blocks"]) == n_done // b and (rows.get("partial") is None) == (n_done % b == 0)
        ok = ok and sum(p["n_instances"] for p in state["parts"]) == n_done
    tally = state.get("tally")
    if ok and tally is not None:
        n_sensors = state["fingerprint"].get("n_sensors")
        ok = (isinstance(tally, dict) and count(tally.get("n_invalid"))
              and all(isinstance(tally.get(k), list) and len(tally[k]) == n_sensors and all(map(count, tally[k]))
                      for k in ("per_sensor_falsified", "falsified_only_by")))
        if ok:  # what the counts mean bounds them (an instance is falsified at most once per sensor)
            n_falsified = state["n_done"] - sum(p["n_candidates"] for p in state["parts"])
            ok = (n_falsified >= 0 and tally["n_invalid"] <= n_falsified
                  and all(c <= n_falsified for c in tally["per_sensor_falsified"])
                  and all(o <= c for o, c in zip(tally["falsified_only_by"], tally["per_sensor_falsified"]))
                  and sum(tally["falsified_only_by"]) <= n_falsified)
    if not ok:
        raise ValueError("damaged: a field is missing or has the wrong type, length or range")
