"""The ``edmf-rs`` command line (also ``python -m edmf_rs``).

User errors (bad arguments, bad project files, unreadable inputs) print one
message and exit with status 2; set ``EDMF_RS_DEBUG=1`` for the traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from .simulators.failures import SimulationError


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="edmf-rs",
        description="Error-domain model falsification (Goulet & Smith 2013) with a Rust core.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    rep = sub.add_parser("reproduce", help="reproduce the paper: figures, Table 1 and results.json")
    rep.add_argument("--out", default="edmf-out", help="output folder (default: %(default)s)")
    rep.add_argument("--seeds", type=int, default=200,
                     help="independent noise draws per method, scenario and n_m (default: %(default)s)")
    rep.add_argument("--seed", type=int, default=0, help="base random seed (default: %(default)s)")

    run = sub.add_parser("run", help="run an identification from a project file (TOML)")
    which = run.add_mutually_exclusive_group(required=True)
    which.add_argument("project", nargs="?", help="project file, e.g. bridge.toml")
    which.add_argument("--example", choices=example_names(),
                       help="run a project shipped with edmf_rs instead of a file")
    run.add_argument("--out", default=None,
                     help="output folder (default: next to the project file; ./NAME for --example)")
    run.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    run.add_argument("--workers", type=int, default=None,
                     help="parallel model runs (default: [model] workers in the project file, else 1)")
    return parser


EXAMPLES = Path(__file__).resolve().parent / "examples" / "projects"


def example_names() -> list[str]:
    return sorted(p.stem for p in EXAMPLES.glob("*.toml"))


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        if args.command == "reproduce":
            from .paper.reproduce import reproduce_cli

            return reproduce_cli(out=args.out, seeds=args.seeds, seed=args.seed)
        from .project.run import run_cli

        if args.example:
            project, out = EXAMPLES / f"{args.example}.toml", args.out or args.example
        else:
            project, out = args.project, args.out
        if args.workers is not None and args.workers < 1:
            raise ValueError(f"--workers: expected a number of parallel runs >= 1, got {args.workers}")
        return run_cli(project, out=out, progress=not args.no_progress, workers=args.workers)
    except SimulationError as exc:  # the model's runs failed: user code, not the project file
        print(f"edmf-rs: error: {exc}", file=sys.stderr)
        return 1
    except (ValueError, TypeError, OSError) as exc:
        if os.environ.get("EDMF_RS_DEBUG"):
            raise
        print(f"edmf-rs: error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:
        notes = [n for n in getattr(exc, "__notes__", []) if "raised by the model" in n]
        if not notes or os.environ.get("EDMF_RS_DEBUG"):
            raise
        print(f"edmf-rs: error: {type(exc).__name__}: {exc} ({notes[0].removeprefix('edmf_rs: ')})", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("edmf-rs: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
