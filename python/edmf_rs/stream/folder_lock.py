"""One run at a time per checkpoint folder: an ``flock`` held on ``.lock``
while a run uses the folder (the OS drops it if the run dies)."""

from __future__ import annotations

import errno
import os
import stat
import tempfile
import warnings
from pathlib import Path

try:
    import fcntl
except ImportError:  # not POSIX: folders are not locked
    fcntl = None

LOCK = ".lock"


def _no_follow(path, flags: int) -> int:
    """Opens without following a final symbolic link (ELOOP instead), and
    without blocking on a FIFO put in the lock file's place."""
    return os.open(path, flags | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0), 0o666)


def folder_path(value) -> Path:
    """The checkpoint folder as a Path; the empty string (which would mean the
    current folder, and its files) is refused."""
    if isinstance(value, bytes):
        value = os.fsdecode(value)
    if not isinstance(value, (str, os.PathLike)):
        raise TypeError(f"checkpoint: expected a folder path (str or os.PathLike), got {type(value).__name__}")
    if os.fspath(value) == "":
        raise ValueError("checkpoint: expected a folder path, got an empty string")
    return Path(value)


class FolderLock:
    """Creates ``folder`` and locks it against a second run writing into it.

    Where nothing can be written (a read-only copy of a finished run, which
    can still be read back; ``unwritable`` then says why), the file system
    has no locks (``flock`` fails, e.g. NFS without a lock daemon) or the
    ``.lock`` is a regular file we may neither write nor read (another
    user's), the run goes on unlocked: the first has nothing to guard, the
    others are warned about. A ``.lock`` that is not a regular file (a
    directory, FIFO, symbolic link) is refused.
    """

    def __init__(self, folder: Path):
        self.unwritable: OSError | None = None
        self._fh = None
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            if not folder.is_dir():
                raise ValueError(f"checkpoint: cannot create folder {folder} "
                                 f"({exc.strerror or exc}); give a writable folder") from None
        try:  # the folder itself, not the .lock an earlier run (maybe another user's) left
            with tempfile.TemporaryFile(dir=folder):
                pass
        except OSError as exc:
            self.unwritable = exc
        fh = None
        for mode in ("a", "r"):  # flock works on a file opened read-only too
            try:
                fh = open(folder / LOCK, mode, opener=_no_follow)
                break
            except OSError as exc:
                if exc.errno == errno.ELOOP:  # a symbolic link: where it points is not ours to touch
                    raise ValueError(f"checkpoint: {folder / LOCK} is a symbolic link, which a run does not "
                                     "follow; remove it (or give another folder)") from None
                continue
        kind = None
        if fh is not None:
            kind = os.fstat(fh.fileno()).st_mode
        else:  # a directory or socket fails both opens: tell it from a file we may not open
            try:
                kind = os.lstat(folder / LOCK).st_mode
            except OSError:  # absent (in a read-only folder)
                pass
        if kind is not None and not stat.S_ISREG(kind):
            if fh is not None:
                fh.close()
            raise ValueError(f"checkpoint: {folder / LOCK} is not a regular file; remove it (or give another folder)")
        if fh is None or fcntl is None:
            if fh is not None:
                fh.close()
            elif self.unwritable is None:  # e.g. another user's .lock with no read permission for us
                warnings.warn(f"checkpoint: cannot open {folder / LOCK} to lock the folder; "
                              "make sure no other run uses it meanwhile", stacklevel=4)
            return
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            fh.close()
            raise ValueError(f"checkpoint: folder {folder} is in use by another run "
                             "(wait for it to finish, or give another folder)") from None
        except OSError as exc:
            fh.close()
            warnings.warn(f"checkpoint: cannot lock folder {folder} ({exc.strerror}); "
                          "make sure no other run uses it meanwhile", stacklevel=4)
            return
        self._fh = fh

    def release(self) -> None:
        """Idempotent. Unlocks explicitly: a process the model forked shares
        the open file, and closing it here alone would leave the lock held."""
        if self._fh is not None:
            fcntl.flock(self._fh, fcntl.LOCK_UN)
            self._fh.close()
            self._fh = None
