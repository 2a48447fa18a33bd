"""What identifies a run's inputs and model across runs, for a checkpoint's fingerprint.

:func:`fingerprint` holds the call, hashes of the measurements and thresholds
and the options; the model's part is :func:`model_fingerprint`.

A qualified name is not enough: two ``lambda t: scale * t`` made with
``scale=1`` and ``scale=2`` share it. :func:`model_fingerprint` hashes what
decides what a Python callable computes: the bytecode of its code (with its
constants, names and nested code, recursively), its defaults, the values in
its closure cells, the simple module-level values it reads, the arguments of
a ``functools.partial``, the state of a callable object or bound method.
Objects that know better (e.g. an external program: its command, templates
and parser) say what identifies them with a ``__edmf_fingerprint__()``
method returning JSON-able data. What cannot be hashed is named in the
fingerprint under ``"unhashable"``, and a folder made with such a model is
not silently reused (see :class:`edmf_rs.stream.checkpoint.Checkpoint`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import pickle
import types

import numpy as np

#: Values hashed by their repr (exact and stable for these types).
_SIMPLE = (type(None), bool, int, float, complex, str, bytes)


#: Module-level values a function reads that are hashed by content (others by type).
_GLOBALS = (*_SIMPLE, np.ndarray, np.generic, tuple, frozenset, types.FunctionType, functools.partial,
            types.ModuleType, type, types.BuiltinFunctionType, np.ufunc)


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
    anything with ``n_sensors``, ``low`` and ``high``; ``options``: JSON
    values, e.g. ``model=`` a :func:`edmf_rs.stream.identity.model_fingerprint`)."""
    return {"call": call, "n_sensors": thresholds.n_sensors, "measurements": digest(measurements),
            "thresholds": digest(thresholds.low, thresholds.high), **options}



class Unhashable(Exception):
    """A part of the model whose content cannot be hashed."""


def model_fingerprint(model) -> dict:
    """What identifies ``model`` across runs, as JSON-able data.

    Parameters
    ----------
    model
        A callable: a function, lambda, ``functools.partial``, bound method,
        callable object or builtin; or any object with a
        ``__edmf_fingerprint__()`` method returning JSON-able data.

    Returns
    -------
    dict
        ``{"name": qualified name, "code": sha256 hex}``, or
        ``{"name": ..., "unhashable": reason}`` when part of the model could
        not be hashed.

    Examples
    --------
    >>> def make(scale):
    ...     return lambda t: scale * t
    >>> model_fingerprint(make(1)) == model_fingerprint(make(1))
    True
    >>> model_fingerprint(make(1)) == model_fingerprint(make(2))
    False
    """
    h = hashlib.sha256()
    try:
        _feed(h, model, depth=0, seen=set())
    except Unhashable as exc:
        return {"name": _name(model), "unhashable": str(exc)}
    return {"name": _name(model), "code": h.hexdigest()[:32]}


def _name(model) -> str:
    target = getattr(model, "func", model)  # functools.partial
    name = getattr(target, "__qualname__", None) or type(target).__qualname__
    return f"{getattr(target, '__module__', '') or ''}.{name}"


def _feed(h, obj, depth: int, seen: set) -> None:
    if depth > 60:
        raise Unhashable("nested too deeply")
    put = h.update
    custom = getattr(type(obj), "__edmf_fingerprint__", None)
    if custom is not None and not isinstance(obj, type):
        try:
            put(b"custom:" + json.dumps(obj.__edmf_fingerprint__(), sort_keys=True).encode())
        except (TypeError, ValueError) as exc:
            raise Unhashable(f"{_name(obj)}.__edmf_fingerprint__() did not return JSON data ({exc})") from None
        return
    if isinstance(obj, _SIMPLE):
        put(f"{type(obj).__name__}:{obj!r};".encode())
    elif isinstance(obj, np.ndarray):
        if obj.dtype.hasobject:
            raise Unhashable("an object array")
        put(f"array:{obj.dtype.str}:{obj.shape};".encode())
        put(np.ascontiguousarray(obj).tobytes())
    elif isinstance(obj, np.generic):
        put(f"scalar:{obj.dtype.str}:{obj!r};".encode())
    elif isinstance(obj, (tuple, list, frozenset, set)):
        items = sorted(obj, key=repr) if isinstance(obj, (set, frozenset)) else obj
        put(f"{type(obj).__name__}:{len(items)}(".encode())
        for item in items:
            _feed(h, item, depth + 1, seen)
        put(b")")
    elif isinstance(obj, dict):
        put(f"dict:{len(obj)}(".encode())
        for key in sorted(obj, key=repr):
            _feed(h, key, depth + 1, seen)
            _feed(h, obj[key], depth + 1, seen)
        put(b")")
    elif isinstance(obj, types.CodeType):
        _feed_code(h, obj, depth, seen)
    elif isinstance(obj, types.FunctionType):
        _feed_function(h, obj, depth, seen)
    elif isinstance(obj, functools.partial):
        put(b"partial:")
        for part in (obj.func, obj.args, obj.keywords):
            _feed(h, part, depth + 1, seen)
    elif isinstance(obj, types.MethodType):
        put(b"method:")
        _feed(h, obj.__func__, depth + 1, seen)
        _feed_state(h, obj.__self__, depth + 1, seen)
    elif isinstance(obj, types.ModuleType):
        put(f"module:{obj.__name__};".encode())
    elif isinstance(obj, (types.BuiltinFunctionType, np.ufunc, type)):
        put(f"named:{getattr(obj, '__module__', '')}.{getattr(obj, '__qualname__', obj.__name__)};".encode())
    elif callable(obj) and isinstance(getattr(type(obj), "__call__", None), types.FunctionType):
        put(f"callable:{_name(obj)}:".encode())
        _feed(h, type(obj).__call__, depth + 1, seen)
        _feed_state(h, obj, depth + 1, seen)
    else:
        _feed_state(h, obj, depth + 1, seen)


def _feed_state(h, obj, depth: int, seen: set) -> None:
    """An object's content: its attributes (recursively) or, failing that, its pickle."""
    if id(obj) in seen:
        h.update(b"cycle;")
        return
    seen.add(id(obj))
    h.update(f"object:{type(obj).__module__}.{type(obj).__qualname__}:".encode())
    state = getattr(obj, "__dict__", None)
    if isinstance(state, dict):
        _feed(h, {k: v for k, v in state.items()}, depth + 1, seen)
        return
    try:
        h.update(pickle.dumps(obj, protocol=4))
    except Exception as exc:  # pickle raises many types
        raise Unhashable(f"a {type(obj).__qualname__} that has no attributes and cannot be pickled ({exc})") from None


def _feed_code(h, code: types.CodeType, depth: int, seen: set) -> None:
    h.update(f"code:{code.co_name}:{code.co_argcount}:{code.co_kwonlyargcount}:".encode())
    h.update(code.co_code)
    h.update(repr(code.co_names).encode())
    h.update(repr(code.co_varnames).encode())
    for const in code.co_consts:  # nested functions' code is among the constants
        _feed(h, const, depth + 1, seen)


def _feed_function(h, fn: types.FunctionType, depth: int, seen: set) -> None:
    if id(fn) in seen:  # a recursive function
        h.update(f"recursion:{fn.__qualname__};".encode())
        return
    seen.add(id(fn))
    h.update(f"function:{fn.__module__}.{fn.__qualname__}:".encode())
    _feed_code(h, fn.__code__, depth + 1, seen)
    _feed(h, fn.__defaults__, depth + 1, seen)
    _feed(h, fn.__kwdefaults__, depth + 1, seen)
    for cell in fn.__closure__ or ():
        try:
            value = cell.cell_contents
        except ValueError:  # an empty cell
            h.update(b"empty-cell;")
            continue
        _feed(h, value, depth + 1, seen)
    # Module-level values the code reads (constants, arrays, functions it calls).
    for name in _global_names(fn.__code__):
        if name in fn.__globals__:
            value = fn.__globals__[name]
            h.update(f"global:{name}=".encode())
            if isinstance(value, _GLOBALS):
                _feed(h, value, depth + 1, seen)
            else:  # e.g. a logger or a cache: its type, not its changing state
                h.update(f"{type(value).__module__}.{type(value).__qualname__};".encode())


def _global_names(code: types.CodeType) -> list[str]:
    names = list(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names += _global_names(const)
    return sorted(set(names))
