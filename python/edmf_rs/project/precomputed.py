"""Precomputed model instances (``[model] predictions`` and ``parameters``), read in chunks.

Like ``edmf_rs.falsify(path)``, the files are streamed: a ``.npy`` array is
read chunk by chunk from its data offset, a CSV with ``pandas.read_csv``
chunks and a Parquet file by record batches, so peak memory follows the
chunk size, not the file size. CSV and Parquet columns are matched by name;
a ``.npy`` array by position.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from ..engine.model import non_finite
from ..engine.sensors import SensorMapping
from .inputs import match_columns, table_columns
from .schema import ModelSpec, ProjectError


def _npy_header(fh, file: Path) -> tuple[tuple[int, ...], bool, np.dtype]:
    version = np.lib.format.read_magic(fh)
    reader = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}.get(version)
    if reader is None:
        raise ProjectError(f"{file}: unsupported .npy version {version}")
    return reader(fh)


def count_rows(file: Path, key: str) -> int:
    """Rows of a .npy, Parquet or CSV file (a CSV is scanned once, in blocks).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "g.npy"; np.save(f, np.zeros((5, 2)))
    >>> count_rows(f, "model.predictions")
    5
    """
    suffix = file.suffix.lower()
    try:
        if suffix == ".npy":
            with open(file, "rb") as fh:
                return int(_npy_header(fh, file)[0][0])
        if suffix == ".parquet":
            import pyarrow.parquet as pq

            return int(pq.ParquetFile(file).metadata.num_rows)
        lines, last = 0, b"\n"
        with open(file, "rb") as fh:
            while block := fh.read(1 << 20):
                lines += block.count(b"\n")
                last = block[-1:]
        return lines - 1 + (last != b"\n")  # the header; a last line without newline
    except ProjectError:
        raise
    except Exception as exc:
        raise ProjectError(f"{file}: cannot read it as {suffix[1:]} ({key}): {exc}") from None


def iter_table(file: Path, columns: Sequence[str] | Sequence[int], key: str, chunk_rows: int) -> Iterator[np.ndarray]:
    """(n, k) float64 chunks of ``columns`` (names for CSV/Parquet, positions for .npy), in order."""
    suffix = file.suffix.lower()
    try:
        if suffix == ".npy":
            yield from _iter_npy(file, [int(c) for c in columns], chunk_rows)
        elif suffix == ".csv":
            yield from _iter_csv(file, [str(c) for c in columns], key, chunk_rows)
        else:
            import pyarrow.parquet as pq

            names = [str(c) for c in columns]
            for batch in pq.ParquetFile(file).iter_batches(batch_size=chunk_rows, columns=names):
                yield np.column_stack([batch.column(n).to_numpy(zero_copy_only=False).astype(np.float64)
                                       for n in names]) if names else np.empty((batch.num_rows, 0))
    except ProjectError:
        raise
    except (ValueError, TypeError) as exc:
        raise ProjectError(f"{file}: expected numbers in every column used ({key}): {exc}") from None


def _iter_csv(file: Path, names: list[str], key: str, chunk_rows: int) -> Iterator[np.ndarray]:
    """Chunks of exactly ``chunk_rows`` rows (the last one shorter), read by pyarrow's streaming
    CSV reader: unlike ``pandas.read_csv(usecols=...)``, it refuses a row with more or fewer
    fields than the header, so a decimal comma (``0,094``) cannot shift the columns after it."""
    import pyarrow as pa
    import pyarrow.csv as pc

    bad = []  # the row pyarrow refused (an exception raised in the handler does not reach us)

    def invalid(row) -> str:
        bad.append(row)
        return "error"

    def batches():
        try:
            yield from pc.open_csv(file, read_options=pc.ReadOptions(use_threads=False),
                                   parse_options=pc.ParseOptions(invalid_row_handler=invalid),
                                   convert_options=pc.ConvertOptions(include_columns=names,
                                                                     column_types=dict.fromkeys(names, pa.float64())))
        except pa.ArrowInvalid:
            if not bad:
                raise
            row = bad[0]
            raise ProjectError(f"{file}: line {row.number}: expected {row.expected_columns} fields as in the "
                               f"header, got {row.actual_columns} ({key}); a decimal comma or a stray delimiter? "
                               f"The line reads {row.text[:60]!r}") from None

    pending, have = [], 0
    for batch in batches():
        pending.append(np.column_stack([batch.column(n).to_numpy(zero_copy_only=False) for n in names])
                       if names else np.empty((batch.num_rows, 0)))
        have += batch.num_rows
        while have >= chunk_rows:
            rows = np.concatenate(pending) if len(pending) > 1 else pending[0]
            yield rows[:chunk_rows]
            pending, have = [rows[chunk_rows:]], have - chunk_rows
    if have:
        yield np.concatenate(pending)


def _iter_npy(file: Path, columns: list[int], chunk_rows: int) -> Iterator[np.ndarray]:
    with open(file, "rb") as fh:
        shape, fortran, dtype = _npy_header(fh, file)
        if len(shape) != 2:
            raise ProjectError(f"{file}: expected a 2-D array (instances, columns), got shape {shape}")
        if dtype.kind not in "fiub" or dtype.hasobject:
            raise ProjectError(f"{file}: expected an array of numbers, got dtype {dtype}")
        n, width = shape
        if fortran:  # column-major: rows are not contiguous, so read through a memory map
            arr = np.load(file, mmap_mode="r")
            for first in range(0, n, chunk_rows):
                yield np.asarray(arr[first:first + chunk_rows][:, columns], dtype=np.float64)
            return
        for first in range(0, n, chunk_rows):
            rows = min(chunk_rows, n - first)
            block = np.empty((rows, width), dtype=dtype)
            view = memoryview(block.reshape(-1).view(np.uint8))
            got = fh.readinto(view)
            if got != view.nbytes:
                raise ProjectError(f"{file}: truncated: expected {n} rows of {width} values, the file ends "
                                   f"after row {first + got // max(block.itemsize * width, 1)}")
            yield np.asarray(block[:, columns], dtype=np.float64)


def read_rows(file: Path, columns, key: str, rows: int) -> np.ndarray:
    """The first ``rows`` rows of ``columns`` (for the check before a run)."""
    for chunk in iter_table(file, columns, key, rows):
        return chunk[:rows]
    return np.empty((0, len(columns)))


def check_precomputed(model: ModelSpec, parameters, all_sensors, sensors, label: str) -> None:
    """The precomputed files exist, their columns match the parameters and sensors
    and, where the count is in the header (.npy, Parquet), their rows agree."""
    names = [p.name for p in parameters]
    found = table_columns(model.parameters, "model.parameters", label)
    match_columns(found, names, set(names), model.parameters, "parameters")
    found = table_columns(model.predictions, "model.predictions", label)
    if isinstance(found, int) and model.sensors is not None:
        if found != len(model.sensors):
            raise ProjectError(f"{model.predictions}: expected {len(model.sensors)} columns (model.sensors: "
                               f"{', '.join(model.sensors)}), got {found}")
    elif isinstance(found, int):
        match_columns(found, [s.name for s in sensors], {s.name for s in all_sensors}, model.predictions, "sensors")
    else:  # named columns: matched by name, others ignored (and reported)
        match_columns(found, [s.name for s in sensors], None, model.predictions, "sensors")
    if model.predictions.suffix.lower() != ".csv" and model.parameters.suffix.lower() != ".csv":
        n_theta = count_rows(model.parameters, "model.parameters")
        n_pred = count_rows(model.predictions, "model.predictions")
        if n_theta != n_pred:
            raise ProjectError(f"{model.predictions}: expected {n_theta} rows (one per parameter set of "
                               f"{model.parameters.name}), got {n_pred}")


def _columns(project, file: Path, names: Sequence[str], positional: Sequence[str]) -> list:
    if file.suffix.lower() == ".npy":
        return [list(positional).index(name) for name in names]
    return list(names)


def first_parameters(project, rows: int) -> np.ndarray:
    """The first ``rows`` parameter sets of the precomputed instances."""
    m = project.model
    names = project.parameter_names
    return read_rows(m.parameters, _columns(project, m.parameters, names, names), "model.parameters", rows)


def precomputed_instances(project):
    """(lookup, parameter batches, N) for falsify_model: parameter chunks checked
    against the domain, and a "model" returning the matching predictions chunk."""
    m = project.model
    names, sensors = project.parameter_names, project.sensor_names
    positional, source = project.positional_sensors
    n = count_rows(m.predictions, "model.predictions")
    if n == 0:
        raise ProjectError(f"{m.parameters}: expected at least one model instance, the file has none")
    size = m.batch_size
    predictions = iter_table(m.predictions, _columns(project, m.predictions, sensors, positional),
                             "model.predictions", size)
    if m.predictions.suffix.lower() == ".npy":
        mapping = SensorMapping(f"by position, columns of {m.predictions.name} in {source}", sensors,
                                tuple(x for x in positional if x not in sensors))
    else:
        found = table_columns(m.predictions, "model.predictions", str(project.file))
        mapping = SensorMapping(f"by name, columns of {m.predictions.name}", sensors,
                                tuple(c for c in found if c not in sensors))

    def parameters() -> Iterator[np.ndarray]:
        offset = 0
        for theta in iter_table(m.parameters, _columns(project, m.parameters, names, names), "model.parameters", size):
            for j, p in enumerate(project.parameters):
                bad = np.flatnonzero(~((theta[:, j] >= p.low) & (theta[:, j] <= p.high)))
                if bad.size:
                    raise ProjectError(f"{m.parameters}: row {offset + bad[0]}: {p.name} = {theta[bad[0], j]:g} is "
                                       f"outside [parameters.{p.name}] = [{p.low:g}, {p.high:g}]; expected values "
                                       "in the domain")
            offset += theta.shape[0]
            yield theta
        if pending or next(predictions, None) is not None:
            raise ProjectError(f"{m.predictions}: expected {offset} rows (one per parameter set of "
                               f"{m.parameters.name}), got more")

    offset = 0
    pending: list[np.ndarray] = []

    def take(k: int) -> np.ndarray:
        """The next k prediction rows, whatever the chunks the file is read in."""
        have = sum(p.shape[0] for p in pending)
        while have < k:
            chunk = next(predictions, None)
            if chunk is None:
                break
            pending.append(chunk)
            have += chunk.shape[0]
        rows = pending[0] if len(pending) == 1 else np.concatenate(pending) if pending else np.empty((0, len(sensors)))
        pending.clear()
        if rows.shape[0] > k:
            pending.append(rows[k:])
        return rows[:k]

    def lookup(batch: np.ndarray) -> np.ndarray:  # batches come in order, of the same size
        nonlocal offset
        rows = take(batch.shape[0])
        if rows.shape[0] != batch.shape[0]:
            raise ProjectError(f"{m.predictions}: expected as many rows as {m.parameters.name} (at least "
                               f"{offset + batch.shape[0]}), got {offset + rows.shape[0]}")
        bad = np.flatnonzero(~np.isfinite(rows).all(axis=1)) if m.nan == "raise" else ()
        if len(bad):
            raise ProjectError(f"{m.predictions}: row {offset + bad[0]}: expected finite predictions, "
                               f"got {non_finite(rows[bad[0]])} (or set nan = \"falsify\" under [model])")
        offset += batch.shape[0]
        return rows

    lookup.mapping = mapping
    return lookup, parameters(), n
