"""The ``edmf-rs`` command line (also ``python -m edmf_rs``).

Exit status: 0 done; 1 the project's own code (its model or a prognosis
function) raised or called sys.exit; 2 a bad argument, project file or input
(one message naming the file, key and what was expected); 130 interrupted.
``--traceback`` (or the environment variable ``EDMF_RS_DEBUG=1``) adds the
traceback to the message.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from pathlib import Path

from . import __version__
from .simulators.failures import SimulationError

EXAMPLES = Path(__file__).resolve().parent / "examples" / "projects"

REPRODUCE = """\
Reproduce Goulet & Smith (2013): judge residual minimisation, Bayesian inference and EDMF on the
paper's cantilever for each scenario and number of sensors over independent noise draws, derive
Table 1 from the rates, and write the figures, the tables and results.json to --out."""

RUN = """\
Run an identification from a project file (TOML): validate it, check the model and prognosis
functions on two instances, sample the parameters, evaluate the model in batches, falsify
(Eq. 8), and write summary.json, candidates.parquet, thresholds.csv, plots and report.html.
A project file runs the code it names (model.function, prognosis functions), like a Python script:
run only project files you trust."""


def example_names() -> list[str]:
    return sorted(p.stem for p in EXAMPLES.glob("*.toml"))


def _parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--traceback", action="store_true", default=argparse.SUPPRESS,
                        help="show the traceback of an error (same as EDMF_RS_DEBUG=1)")
    parser = argparse.ArgumentParser(
        prog="edmf-rs", parents=[common],
        description="Error-domain model falsification (Goulet & Smith 2013) with a Rust core.",
        epilog="Exit status: 0 done, 1 the project's code failed, 2 bad arguments, project file or inputs, "
               "130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"edmf-rs {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    rep = sub.add_parser("reproduce", parents=[common], description=REPRODUCE,
                         help="reproduce the paper: figures, Table 1 and results.json")
    rep.add_argument("--out", default="edmf-out", help="output folder (default: %(default)s); refused when it "
                     "holds files a reproduction does not write, unless --force")
    rep.add_argument("--force", action="store_true", help="write into an --out folder that holds other files")
    rep.add_argument("--seeds", type=int, default=200,
                     help="independent noise draws per method, scenario and n_m (default: %(default)s)")
    rep.add_argument("--seed", type=int, default=0, help="base random seed (default: %(default)s)")

    run = sub.add_parser("run", parents=[common], description=RUN,
                         help="run an identification from a project file (TOML)")
    which = run.add_mutually_exclusive_group(required=True)
    which.add_argument("project", nargs="?", help="project file, e.g. bridge.toml")
    which.add_argument("--example", choices=example_names(),
                       help="run a project shipped with edmf_rs instead of a file")
    run.add_argument("--out", default=None,
                     help="output folder (default: next to the project file; ./NAME for --example); refused "
                          "when not empty unless it holds an earlier run of the same project")
    run.add_argument("--force", action="store_true",
                     help="write into a non-empty --out folder (inputs of the project and files a run did not "
                          "write are never overwritten)")
    run.add_argument("--dry-run", action="store_true",
                     help="validate, check the model on two instances, print the plan and estimate; "
                          "run nothing else and write nothing")
    run.add_argument("--yes", action="store_true",
                     help="go ahead with a run over 10^10 instances or estimated at more than a day")
    run.add_argument("--threads", type=int, default=None, metavar="N",
                     help="threads of the Rust core (default: all cores)")
    run.add_argument("--no-progress", action="store_true", help="hide the progress line")
    run.add_argument("--workers", type=int, default=None, metavar="N",
                     help="parallel model runs (default: [model] workers in the project file, else 1)")
    run.add_argument("--scheduler", default=None, metavar="ADDRESS",
                     help="evaluate the Python model on this Dask scheduler, e.g. tcp://host:8786 (default: "
                          "[compute] scheduler in the project file)")
    run.add_argument("--retry-failures", action="store_true",
                     help="run again the failed instances the prediction store holds (by default only those "
                          "that timed out under a shorter timeout are run again)")

    from .project.refalsify import add_parser as add_falsify

    add_falsify(sub, common)  # edmf-rs falsify STORE --project P.toml

    from .design.cli import add_parser as add_design

    add_design(sub, common)  # edmf-rs design PROJECT.toml
    return parser


def main(argv: list[str] | None = None) -> int:
    try:
        args = _parser().parse_args(argv)
    except KeyboardInterrupt:
        print("edmf-rs: interrupted", file=sys.stderr)
        return 130
    debug = getattr(args, "traceback", False) or bool(os.environ.get("EDMF_RS_DEBUG"))
    try:
        if args.command == "reproduce":
            from .paper.command import reproduce_cli

            return reproduce_cli(out=args.out, seeds=args.seeds, seed=args.seed, force=args.force)
        if args.command == "design":
            from .design.cli import design_cli

            return design_cli(args.project, out=args.out, force=args.force)
        if args.command == "falsify":
            from .project.refalsify import falsify_cli

            return falsify_cli(args.store, args.project, out=args.out, progress=not args.no_progress,
                               force=args.force)
        from .project.command import run_cli

        if args.example:
            project, out = EXAMPLES / f"{args.example}.toml", args.out or args.example
        else:
            project, out = args.project, args.out
        if args.workers is not None and args.workers < 1:
            raise ValueError(f"--workers: expected a number of parallel runs >= 1, got {args.workers}")
        return run_cli(project, out=out, progress=not args.no_progress, dry_run=args.dry_run, yes=args.yes,
                       force=args.force, threads=args.threads, workers=args.workers, scheduler=args.scheduler,
                       retry_failures=args.retry_failures)
    except KeyboardInterrupt:
        print("edmf-rs: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        from .project.errors import UserCodeError

        if isinstance(exc, (UserCodeError, SimulationError)):  # the model's code or runs failed
            status = 1
        elif isinstance(exc, (ValueError, TypeError, OSError)):
            status = 2
        else:
            notes = [n for n in getattr(exc, "__notes__", []) if "raised by the model" in n]
            if not notes:
                raise  # a fault of edmf_rs itself: the traceback is the report
            exc = UserCodeError(f"{type(exc).__name__}: {exc} ({notes[0].removeprefix('edmf_rs: ')})", exc)
            status = 1
        if debug:
            traceback.print_exception(getattr(exc, "original", exc), file=sys.stderr)
        print(f"edmf-rs: error: {exc}", file=sys.stderr)
        return status


if __name__ == "__main__":
    sys.exit(main())
