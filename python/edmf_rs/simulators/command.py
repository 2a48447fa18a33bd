"""External programs as models: one run per model instance, in its own work folder.

For each instance the templates (``files``) are copied into a fresh, uniquely
named folder with their ``{NAME}`` placeholders replaced by the instance's
parameters, the command runs there (stdout and stderr go to files in the
folder), and the output file is parsed into one prediction per sensor. A
failed run leaves its folder for inspection; a successful one removes it
unless ``keep_work``. Runs never raise: a failure is returned as a
:class:`~edmf_rs.simulators.failures.Failure` (failures are data).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import tempfile
import threading
from dataclasses import dataclass, field
from pathlib import Path

from . import parsers
from .failures import Failure
from .template import check_names, check_placeholders, render

#: Files named by the command line up to this size are hashed into the fingerprint;
#: larger ones are recorded by size and modification time (hashing them would stall start-up).
HASH_LIMIT = 256 * 2**20


@dataclass(frozen=True)
class CommandSpec:
    """``[model]`` for an external program, as written in the project file.

    Attributes
    ----------
    command : tuple of str
        Program and arguments (placeholders allowed).
    files : tuple of str
        Templates, relative to ``path``, copied into each run's work folder
        with ``{NAME}`` replaced by the instance's parameters. Any other argument
        naming a file in ``path`` (a script after an interpreter) is passed as
        that file's absolute path, since runs start in their work folders.
    output, parser : str, str or None
        The file the program writes, and its parser (``module:function``, or
        None for .csv/.json).
    timeout : float or None
        Seconds per run (None: no limit).
    keep_work : bool
        Keep the work folders of successful runs too.

    Examples
    --------
    >>> CommandSpec(("ccx", "-i", "girder"), files=("girder.inp",), output="girder.dat").timeout is None
    True
    """

    command: tuple[str, ...]
    files: tuple[str, ...] = ()
    output: str = "results.csv"
    parser: str | None = None
    path: Path = Path(".")
    timeout: float | None = None
    keep_work: bool = False
    options: dict = field(default_factory=dict)


class CommandModel:
    """A checked :class:`CommandSpec`: program found, templates read and their
    placeholders checked against the parameters, parser imported.

    Parameters
    ----------
    spec
        The command as written.
    parameters
        Parameter names, in the order of a parameter row.
    sensors
        Sensor names the output must give, in the order of the prediction columns.

    Raises
    ------
    ValueError
        Naming the template and placeholder, the missing program or file, or the parser.

    Examples
    --------
    >>> import sys, tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "deck.txt").write_text("sensor,value\\nS,{a}\\n")
    >>> model = CommandModel(CommandSpec(("cp", "deck.txt", "results.csv"), ("deck.txt",), path=d), ("a",), ("S",))
    >>> model.run(0, [0.1], d)
    [0.1]
    >>> CommandModel(CommandSpec(("cp", "{b}", "x"), path=d), ("a",), ("S",))
    Traceback (most recent call last):
    ...
    edmf_rs.simulators.template.TemplateError: command[1] ('{b}'): placeholder {b} names no parameter (the parameters are: a)
    """

    def __init__(self, spec: CommandSpec, parameters, sensors):
        self.spec, self.parameters, self.sensors = spec, tuple(parameters), tuple(sensors)
        if not spec.command:
            raise ValueError("command: expected a program and its arguments, got an empty list")
        check_names(self.parameters)
        for name in spec.files:
            _check_relative("files", name)
        _check_relative("output", spec.output)
        for i, arg in enumerate(spec.command):
            check_placeholders(arg, self.parameters, f"command[{i}] ({arg!r})")
        program = spec.command[0]
        if os.sep in program and not os.path.isabs(program):  # relative to the project file's folder
            program = str((spec.path / program).resolve())
        found = shutil.which(program) if os.sep not in program else (program if os.access(program, os.X_OK) else None)
        if found is None:
            raise ValueError(f"command: program '{program}' not found (looked on PATH)"
                             if os.sep not in program else f"command: '{program}' is not an executable file")
        self.program = found
        self.templates: dict[str, str] = {}
        for name in spec.files:
            file = spec.path / name
            try:
                text = file.read_text("utf-8")
            except OSError as exc:
                raise ValueError(f"files: cannot read template '{file}': {exc.strerror or exc}") from None
            except UnicodeDecodeError:
                raise ValueError(f"files: template '{file}' is not UTF-8 text; expected a text input deck") from None
            check_placeholders(text, self.parameters, str(file))
            self.templates[name] = text
        self.parser = parsers.resolve(spec.parser, spec.output, spec.path)
        self.project_files = _project_file_arguments(spec)
        self._program_files: dict | None = None  # sha256 of the files the command names (fingerprint)
        self._cleaner = None  # removes successful work folders off the runs' critical path
        self._running: set[subprocess.Popen] = set()
        self._lock = threading.Lock()

    def kill_running(self) -> None:
        """Kills the runs in progress (their instances fail; used when the run stops)."""
        with self._lock:
            running = list(self._running)
        for proc in running:
            _kill_group(proc)

    def wait_for_cleanup(self) -> None:
        """Returns once every successful run's work folder is removed."""
        if self._cleaner is not None:
            self._cleaner.shutdown(wait=True)
            self._cleaner = None

    def fingerprint(self) -> dict:
        """What decides the predictions: the command line, the program's path, the contents of
        every file the command line names (the program itself, resolved on PATH like a run does,
        and arguments naming an existing file, e.g. the script after an interpreter, relative to
        the project folder: sha256, or size and modification time above :data:`HASH_LIMIT`),
        template contents, output, parser (and its module's source)."""
        digest = hashlib.sha256()
        for name, text in sorted(self.templates.items()):
            digest.update(name.encode() + b"\0" + text.encode() + b"\0")
        if self._program_files is None:  # once per model: the files are read at start-up
            self._program_files = self._command_files()
        return {"kind": "command", "command": list(self.spec.command), "program": self.program,
                "program_files": self._program_files,
                "templates": digest.hexdigest(), "output": self.spec.output, "parser": self.spec.parser,
                "parser_source": _source_digest(self.parser) if self.spec.parser else None}

    def _command_files(self) -> dict[str, str]:
        """``{argument: digest}`` for the program and each argument that names a regular file."""
        out = {}
        for i, arg in enumerate(self.spec.command):
            if i == 0:
                path = Path(self.program)
            elif not arg or "{" in arg:  # empty, or rendered per instance (a template's contents count)
                continue
            else:
                path = Path(arg) if os.path.isabs(arg) else self.spec.path / arg
            key = arg if i else self.spec.command[0]
            if key not in out:
                digest = _file_digest(path)
                if digest is not None:
                    out[key] = digest
        return out

    def run(self, index: int, theta, root: Path) -> list[float] | Failure:
        """Runs instance ``index`` with parameter row ``theta`` in a new folder under ``root``."""
        values = dict(zip(self.parameters, (float(v) for v in theta)))
        params = tuple(values.values())
        command = [self.program, *(self.project_files.get(i) or render(a, values)
                                   for i, a in enumerate(self.spec.command[1:], 1))]
        work = Path(tempfile.mkdtemp(prefix=f"instance-{index:09d}-", dir=root))
        try:
            for name, text in self.templates.items():
                target = work / name
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_text(render(text, values), "utf-8")
            reason = self._execute(command, work)
            if reason is None:
                output = work / self.spec.output
                if not output.is_file():
                    reason = f"output file '{self.spec.output}' missing after the run"
                else:
                    try:
                        result = parsers.predictions(self.parser(output), self.sensors, self.spec.output)
                    except Exception as exc:  # a parser that raises fails this instance only
                        reason = f"parsing {self.spec.output} failed: {type(exc).__name__}: {exc}"
        except OSError as exc:
            reason = f"preparing the work folder failed: {exc}"
        if reason is None:
            if not self.spec.keep_work:
                if self._cleaner is None:
                    from concurrent.futures import ThreadPoolExecutor

                    self._cleaner = ThreadPoolExecutor(1, thread_name_prefix="edmf-rs-cleanup")
                self._cleaner.submit(shutil.rmtree, work, ignore_errors=True)
            return result
        return Failure(index, params, f"{reason} (command: {' '.join(command)})", _tail(work / "stderr.txt"),
                       str(work), timeout=self.spec.timeout if reason.startswith("timed out") else None)

    def _execute(self, command: list[str], work: Path) -> str | None:
        """Runs the command in ``work``; the reason it failed, or None."""
        with open(work / "stdout.txt", "wb") as out, open(work / "stderr.txt", "wb") as err:
            try:
                # Its own session, so a timeout kills the solver and its children.
                proc = subprocess.Popen(command, cwd=work, stdout=out, stderr=err, stdin=subprocess.DEVNULL,
                                        start_new_session=True)
            except OSError as exc:
                return f"could not start the command: {exc}"
            with self._lock:
                self._running.add(proc)
            try:
                code = proc.wait(timeout=self.spec.timeout)
            except subprocess.TimeoutExpired:
                _kill_group(proc)
                return f"timed out after {self.spec.timeout:g} s"
            except BaseException:  # Ctrl-C: do not leave the solver running
                _kill_group(proc)
                raise
            finally:
                with self._lock:
                    self._running.discard(proc)
        if code < 0:
            try:
                name = signal.Signals(-code).name
            except ValueError:
                name = str(-code)
            return f"killed by signal {name}"
        if code != 0:
            return f"exit code {code}"
        return None


def _project_file_arguments(spec: CommandSpec) -> dict[int, str]:
    """``{position: absolute path}`` of the arguments naming a file beside the project file (a script
    after an interpreter), passed so, since each run starts in its own work folder. Templates (copied
    into it), the output file and arguments with a placeholder are passed as written."""
    written = {os.path.normpath(name) for name in (*spec.files, spec.output)}
    return {i: str((spec.path / arg).resolve()) for i, arg in enumerate(spec.command) if i
            and arg and "{" not in arg and not os.path.isabs(arg) and os.path.normpath(arg) not in written
            and (spec.path / arg).is_file()}


def _check_relative(key: str, name: str) -> None:
    """Refuses a ``files`` or ``output`` path that is not inside each run's work folder."""
    what = ("a template's path relative to the project folder (it is read from there and written to the "
            "same relative path in each run's work folder)" if key == "files" else
            "the output file's path relative to each run's work folder (where the program runs)")
    norm = os.path.normpath(name) if name else ""
    if not name or os.path.isabs(name) or norm in (".", "..") or norm.startswith(".." + os.sep):
        raise ValueError(f"{key}: expected {what}, without '..' leaving it, got {name!r}")


def _file_digest(path: Path) -> str | None:
    """``sha256:<hex>`` of a regular file (``size:<bytes>,mtime:<ns>`` above :data:`HASH_LIMIT`), else None."""
    try:
        if not path.is_file():
            return None
        st = path.stat()
        if st.st_size > HASH_LIMIT:
            return f"size:{st.st_size},mtime:{st.st_mtime_ns}"
        digest = hashlib.sha256()
        with open(path, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                digest.update(chunk)
        return "sha256:" + digest.hexdigest()
    except OSError:
        return None


def _kill_group(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        proc.kill()
    proc.wait()


def _tail(path: Path, lines: int = 20) -> str:
    try:
        with open(path, "rb") as fh:
            fh.seek(0, os.SEEK_END)
            fh.seek(max(0, fh.tell() - 4096))
            return "\n".join(fh.read().decode("utf-8", "replace").splitlines()[-lines:])
    except OSError:
        return ""


def _source_digest(func) -> str | None:
    """sha256 of the file that defines ``func`` (its helpers change results too), else of its bytecode."""
    import inspect
    import marshal

    try:
        return hashlib.sha256(Path(inspect.getsourcefile(func)).read_bytes()).hexdigest()
    except (TypeError, OSError):
        code = getattr(func, "__code__", None)
        return hashlib.sha256(marshal.dumps(code)).hexdigest() if code is not None else None
