"""``edmf-rs falsify STORE --project P.toml``: the falsification again, from a prediction store.

Every instance's predictions are read from the store an earlier ``edmf-rs
run`` kept (``OUT/store/<key>``, see :mod:`edmf_rs.simulators.store`); the
model is not evaluated once. The project's current uncertainty sources, phi,
correction, measured values and excluded sensors apply, so the outputs are
those of ``edmf-rs run`` on the same project (``summary.json`` reports
``model_evaluations`` 0). Refused before anything runs (exit status 2): a
path that is not a store, a store of another model or sampling (both named),
a store that lacks some of the project's sensors or instances.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from ..simulators.store import SCHEMA, PredictionStore, store_key
from ..stream.atomic import write_text
from .command import check_out, default_out, mark
from .external import project_fingerprint
from .run import Project
from .schema import ProjectError

HELP = """\
Falsify again from the prediction store of an earlier `edmf-rs run` (STORE: its output folder, its
store/ folder or one model's store/<key> folder), with the project's current uncertainty sources, phi,
correction, measurements and excluded sensors: no model evaluation. Writes the outputs of `run`."""


def add_parser(sub, common) -> None:
    """The ``falsify`` subcommand of ``edmf-rs``."""
    cmd = sub.add_parser("falsify", parents=[common], description=HELP,
                         help="falsify again from a prediction store, evaluating no model")
    cmd.add_argument("store", help="prediction store: an earlier run's --out folder, OUT/store or OUT/store/KEY")
    cmd.add_argument("--project", required=True, help="project file whose model made the store, e.g. bridge.toml")
    cmd.add_argument("--out", default=None, help="output folder (default: next to the project file)")
    cmd.add_argument("--force", action="store_true", help="write into a non-empty --out folder")
    cmd.add_argument("--no-progress", action="store_true", help="hide the progress line")


def _manifest(folder: Path) -> dict:
    path = folder / "manifest.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ProjectError(f"{path}: expected a prediction store's manifest (JSON), could not read it: {exc}") from None
    if not isinstance(data, dict) or data.get("schema") != SCHEMA or "fingerprint" not in data:
        raise ProjectError(f"{path}: expected a prediction store manifest with schema {SCHEMA!r}")
    return data


def _model_text(fingerprint: dict) -> str:
    model = fingerprint.get("model", {}) if isinstance(fingerprint, dict) else {}
    if isinstance(model, dict) and model.get("kind") == "function":
        return f"function {model.get('ref')!r} (source digest {str(model.get('source'))[:12]})"
    return f"command {json.dumps(model, sort_keys=True, default=str)[:160]}"


def find_store(path: str | Path, project: Project) -> Path:
    """The store folder of ``project``'s model and sampling under ``path``, checked to hold all it needs.

    Parameters
    ----------
    path : str or pathlib.Path
        An earlier run's output folder, its ``store`` folder, or one
        ``store/<key>`` folder.
    project : Project
        The project to falsify.

    Returns
    -------
    pathlib.Path
        The ``<root>/<key>`` folder holding every instance of the project.

    Raises
    ------
    ProjectError
        When ``path`` is missing or not a store, holds another model or
        sampling (both named), lacks sensors the project uses, or holds fewer
        instances than the project has.

    Examples
    --------
    >>> import tempfile, edmf_rs
    >>> from edmf_rs import cli
    >>> project = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml")
    >>> try:
    ...     find_store(tempfile.mkdtemp(), project)
    ... except edmf_rs.ProjectError as exc:
    ...     print("not a prediction store" in str(exc))
    True
    """
    if project.sampling is None or project.model.predictions is not None:
        raise ProjectError(f"{project.file}: model: precomputed predictions have no prediction store; "
                           "expected a project whose model is a function or a command (run it with edmf-rs run)")
    if getattr(project.sampling, "method", None) == "adaptive":
        raise ProjectError(f"{project.file}: sampling: adaptive sampling keeps no prediction store; expected "
                           "method = 'grid', 'sobol' or 'lhs'")
    base = Path(path)
    if not base.is_dir():
        raise ProjectError(f"{base}: no such prediction store; expected a folder written by edmf-rs run "
                           "(its --out folder, OUT/store or OUT/store/KEY)")
    if (base / "manifest.json").is_file():
        folders = [base]
    else:
        root = base / "store" if (base / "store").is_dir() else base
        folders = sorted(f for f in root.iterdir() if (f / "manifest.json").is_file())
    if not folders:
        raise ProjectError(f"{base}: not a prediction store: expected a folder holding manifest.json and "
                           "part-*.parquet files (OUT/store/KEY, written by edmf-rs run), or a folder holding such")
    want = project_fingerprint(project)
    key = store_key(want)
    manifests = {f: _manifest(f) for f in folders}
    match = [f for f, m in manifests.items() if store_key(m["fingerprint"]) == key and f.name == key]
    if not match:
        raise ProjectError(_mismatch(manifests, want, key, project))
    folder = match[0]
    store = PredictionStore(folder.parent, want, project.parameter_names, [s.name for s in project.all_sensors])
    covered = store.covered()
    if covered < project.n_instances:
        raise ProjectError(f"{folder}: the store holds instances 0..{covered - 1} ({covered:,}), {project.file.name} "
                           f"has {project.n_instances:,}; expected a store holding every instance (evaluate the "
                           "rest with edmf-rs run)")
    return folder


def _mismatch(manifests: dict, want: dict, key: str, project: Project) -> str:
    """Why no store fits: the first store's model, parameters or sensors against the project's."""
    folder, manifest = next(iter(manifests.items()))
    have, want = manifest["fingerprint"], json.loads(json.dumps(want, default=str))  # as the manifest holds it
    label = project.file.name
    lacking = [s for s in project.sensor_names if s not in manifest.get("sensors", ())]
    others = f" (and {len(manifests) - 1} other stores)" if len(manifests) > 1 else ""
    if lacking:
        return (f"{folder}: the store{others} holds no predictions for sensor(s) {', '.join(lacking)} of {label}; "
                f"it has {', '.join(manifest.get('sensors', ())) or 'none'}")
    if have.get("model") != want["model"]:
        return (f"{folder}: the store{others} holds another model: {_model_text(have)} (store key {folder.name}); "
                f"expected the model of {label}: {_model_text(want)} (key {key})")
    hs, ws = have.get("sampling") or {}, want["sampling"]
    if hs.get("parameters") != ws["parameters"] or hs.get("method") != ws["method"] or hs.get("seed") != ws["seed"] \
            or hs.get("points") != ws["points"] or hs.get("n") != ws["n"]:
        def show(s):
            return (f"{s.get('method')} sampling (seed {s.get('seed')}, n {s.get('n')}) of "
                    f"{[tuple(p) for p in s.get('parameters') or ()]}")
        return (f"{folder}: the store{others} holds other parameters: {show(hs)} (store key {folder.name}); "
                f"expected those of {label}: {show(ws)} (key {key})")
    return (f"{folder}: the store{others} was made with other sensors ({', '.join(hs.get('sensors') or ())}); "
            f"expected those of {label}'s measurements ({', '.join(ws['sensors'])}), store key {folder.name}, "
            f"expected {key}")


def falsify_cli(store: str | Path, project_path: str | Path, out: str | Path | None = None, progress: bool = True,
                *, force: bool = False) -> int:
    """``edmf-rs falsify STORE --project P.toml [--out DIR]``; returns the exit status.

    Parameters
    ----------
    store : str or pathlib.Path
        The prediction store (see `find_store`).
    project_path : str or pathlib.Path
        The project file.
    out : str or pathlib.Path, optional
        The output folder (default: next to the project file).
    progress : bool, default True
        Show the progress line.
    force : bool, default False
        Write into a non-empty folder that holds no earlier run of the project.

    Returns
    -------
    int
        0 when done.

    Raises
    ------
    ProjectError
        When the project, the store or the output folder cannot be used.

    Examples
    --------
    >>> import tempfile
    >>> from edmf_rs import cli
    >>> try:
    ...     falsify_cli(tempfile.mkdtemp() + "/missing", cli.EXAMPLES / "cantilever.toml")
    ... except ValueError as exc:
    ...     print("no such prediction store" in str(exc))
    True
    """
    started = time.perf_counter()
    project = Project.from_toml(project_path)
    folder = find_store(store, project)
    out_dir = Path(out) if out is not None else default_out(project_path)
    check_out(out_dir, project, force)
    mark(out_dir, project)
    print(f"falsifying {project.n_instances:,} instances of {project.file.name} from {folder} "
          "(no model evaluation)", file=sys.stderr)
    identification = project.run(progress=progress, out=out_dir, store=folder)
    identification.write(out_dir)
    stale = (identification.evaluation or {}).get("failures_not_retried", 0)
    note = _not_retried_note(stale, project)
    if note:
        _add_to_summary(out_dir / "summary.json", {"failures_not_retried": stale, "failures_not_retried_note": note})
    print(identification.summary())
    if note:
        print(note)
    print(f"wrote {out_dir}/ (report.html, summary.json, candidates.parquet, thresholds.csv, plots) "
          f"in {time.perf_counter() - started:.1f} s")
    return 0


def _not_retried_note(stale: int, project: Project) -> str:
    """What to say of stored failures a run would retry (timed out under a shorter timeout), if any."""
    if not stale:
        return ""
    timeout = getattr(getattr(project.command, "spec", None), "timeout", None)
    longer = f" than model.timeout = {timeout:g} s of {project.file.name}" if timeout is not None else ""
    return (f"{stale:,} failed instance{'s' if stale != 1 else ''} timed out under a shorter timeout{longer}: "
            f"reported as failed, as stored (falsify evaluates no model); `edmf-rs run {project.file.name} "
            "--out` on the store's folder runs them again")


def _add_to_summary(path: Path, extra: dict) -> None:
    """summary.json with ``extra`` keys added (rewritten atomically)."""
    data = json.loads(path.read_text(encoding="utf-8"))
    data.update(extra)
    write_text(path, json.dumps(data, indent=2) + "\n")


__all__ = ["falsify_cli", "find_store"]
