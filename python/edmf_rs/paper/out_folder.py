"""The output folder of ``edmf-rs reproduce``: written into only when it is new, empty or an
earlier reproduction's, so that a user's files there (a ``results.json`` of their own) are
never replaced without ``--force``."""

from __future__ import annotations

import json
from pathlib import Path

def check_out(out: Path, files, force: bool) -> None:
    """Refuses an output folder that holds other files than ``files``, the names a reproduction
    writes (a ``results.json`` that is not a reproduction's counts as another), unless ``force``."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: expected a folder, it is a file")
    if not out.is_dir() or force:
        return
    foreign = sorted(p.name for p in out.iterdir() if p.name not in files)
    try:
        earlier = json.loads((out / "results.json").read_text(encoding="utf-8"))
        if not (isinstance(earlier, dict) and "paper_table1" in earlier):
            foreign.append("results.json")
    except FileNotFoundError:
        pass
    except (OSError, ValueError):
        foreign.append("results.json")
    if foreign:
        raise ValueError(f"--out {out}: the folder holds files a reproduction did not write "
                         f"({', '.join(foreign[:3])}{', ...' if len(foreign) > 3 else ''}); choose an empty "
                         "or new folder, or pass --force to write into it")


__all__ = ["check_out"]
