"""``edmf-rs run``: check the project and the output folder, print the plan,
run, write the outputs, print a short summary.

Everything that can be refused is refused before the run: a project file or
input that cannot be used, an ``--out`` that names a file or a folder holding
other things than a previous run of this project (unless ``--force``), an
output that would overwrite one of the project's inputs (always), a run over
the size limits without ``--yes``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from .plan import MAX_SECONDS, check_instances
from .result import ADAPTIVE_FILES, OUTPUT_FILES
from .run import Project
from .schema import ProjectError

#: Written first into the output folder: the project file a run there belongs to.
MARKER = ".edmf-rs-run"


def default_out(project_file: str | Path) -> Path:
    """The output folder next to the project file, named after it."""
    project_file = Path(project_file)
    return project_file.with_name(project_file.stem)


def _previous_run_of(out: Path, project: Project) -> bool:
    marker = out / MARKER
    if marker.is_file():
        return marker.read_text(encoding="utf-8").strip() == str(project.file.resolve())
    try:
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(summary, dict) and summary.get("project", {}).get("file") == project.file.name \
        and summary.get("project", {}).get("name") == project.name


def mark(out: Path, project: Project) -> None:
    """Creates the output folder and writes the marker naming the project file."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / MARKER).write_text(str(project.file.resolve()) + "\n", encoding="utf-8")
    except OSError as exc:
        raise ProjectError(f"--out {out}: cannot write the output folder ({exc.strerror or exc}); "
                           "expected a folder this user can create and write to") from None


def check_out(out: Path, project: Project, force: bool, outputs=(*OUTPUT_FILES, *ADAPTIVE_FILES, MARKER),
              what: str = "run") -> None:
    """Refuses an output folder the run must not write into (see the module docstring).

    Raises
    ------
    ProjectError
        ``--out`` names a file; or a non-empty folder that is not a previous
        run of this project (without ``force``); or an output would replace
        an input of the project (even with ``force``).
    """
    if out.exists() and not out.is_dir():
        raise ProjectError(f"--out {out}: expected a folder, it is a file")
    inputs = [f.resolve() for f in project.inputs]
    for name in outputs:
        target = (out / name).resolve()
        if target in inputs:
            raise ProjectError(f"--out {out}: the {what} would overwrite {target}, an input of {project.file.name}; "
                               "choose another output folder")
    if out.is_dir() and any(out.iterdir()) and not _previous_run_of(out, project):
        if not force:
            raise ProjectError(f"--out {out}: the folder is not empty and holds no earlier {what} of "
                               f"{project.file.name}; choose an empty or new folder, or pass --force to write into it")
        if not (out / MARKER).is_file():  # no edmf-rs run's folder: its files are the user's
            adaptive = getattr(getattr(project, "sampling", None), "method", None) == "adaptive"
            written = [n for n in (*outputs, "failures.csv") if n != MARKER and (adaptive or n not in ADAPTIVE_FILES)]
            taken = sorted(name for name in written if (out / name).exists())
            if taken:
                raise ProjectError(f"--out {out}: --force writes into the folder but never replaces files a {what} "
                                   f"did not write, and it holds {', '.join(taken)}; move them or choose another "
                                   "output folder")


def run_cli(project_path: str | Path, out: str | Path | None = None, progress: bool = True, *,
            dry_run: bool = False, yes: bool = False, force: bool = False, threads: int | None = None,
            workers: int | None = None, scheduler: str | None = None, retry_failures: bool = False) -> int:
    """``edmf-rs run PROJECT.toml [--out DIR] [--workers N] [--scheduler ADDRESS] [--retry-failures]``:
    the whole run; returns the exit status."""
    started = time.perf_counter()
    if threads is not None:
        from .._core import set_num_threads

        if threads < 1:
            raise ProjectError(f"--threads: expected a positive number of threads, got {threads}")
        try:
            set_num_threads(threads)
        except ValueError as exc:  # too many: the core's bound, said of this option
            raise ProjectError(f"--threads: {str(exc).removeprefix('n: ')}") from None
    project = Project.from_toml(project_path)
    if scheduler is not None and getattr(project.sampling, "method", None) == "adaptive":
        raise ProjectError(f"--scheduler {scheduler}: not with method = \"adaptive\" in {project.file} (its waves "
                           "run the model in this process)")
    if out is not None and not str(out).strip():
        raise ProjectError("--out: expected an output folder, got an empty name")
    out_dir = Path(out) if out is not None else default_out(project_path)
    check_out(out_dir, project, force)
    check_instances(project.n_instances, yes, where=f"{project.file}: sampling")
    plan = project.check(workers)
    if dry_run:
        print(plan.describe())
        print(f"outputs: {out_dir}/ (dry run: the model checked on two instances, nothing else evaluated, "
              "no output written)")
        return 0
    print(plan.describe().splitlines()[0], file=sys.stderr)
    # The folder is this project's from now on (its store and work folders are written during the
    # run), so a killed run's folder is recognised as an earlier run of the same project.
    earlier = _previous_run_of(out_dir, project)
    mark(out_dir, project)
    identification = project.run(progress=progress, max_seconds=None if yes else MAX_SECONDS, out=out_dir,
                                 workers=workers, scheduler=scheduler, retry_failures=retry_failures)
    identification.write(out_dir)
    if earlier:  # an earlier run's output this run does not write would pass for this run's
        for name in set(OUTPUT_FILES + ADAPTIVE_FILES) - set(identification.output_files()):
            if (out_dir / name).is_file():
                (out_dir / name).unlink()
    print(identification.summary())
    print(f"wrote {out_dir}/ (report.html, summary.json, candidates.parquet, thresholds.csv, plots) "
          f"in {time.perf_counter() - started:.1f} s")
    return 0


__all__ = ["check_out", "default_out", "mark", "run_cli"]
