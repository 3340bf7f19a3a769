"""The workspace: one folder holding the store, cached builds, run folders and sweep outputs.

A ``Workspace`` is an explicit object: the CLI makes one from ``--home`` (or ``HARNESS_HOME``, or
``.harness`` in the project checkout) and activates it for the command; nothing changes the process
environment. It is also the only place that deletes folders (``remove_tree``), and it refuses any path
outside its home, so no input - a run named ``..``, a test case path, a target name - can delete a folder
elsewhere. Cross-process locks (``lock``) use the ``filelock`` package: several harness processes may share
a workspace.
"""
from __future__ import annotations

import contextlib
import fcntl
import os
import re
import shutil
from dataclasses import dataclass
from pathlib import Path

from filelock import FileLock

from harness.adapters.base import UserError

PROJECT_ROOT = Path(__file__).resolve().parents[2]

#: characters a target, test case folder or run name may hold: one path segment, printable, no separators
_SEGMENT = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.,:=@+\-]*$")
#: folder names below a test case with a fixed meaning (thesis 4.3.1); never a test case or a run name
RESERVED_NAMES = frozenset({"post", "meshes", "scripts", "restart", "__pycache__"})


def segment_problem(name) -> str | None:
    """Why ``name`` is not a safe single path segment (None: it is).

    Allowed: letters, digits and ``_ . , : = @ + -``, not starting with ``.`` or ``-``, at most 200
    characters, not a reserved folder name. Sweep points (``settle@DT=1e-05``) pass.
    """
    if not isinstance(name, str) or not name:
        return "must be a non-empty name"
    if len(name) > 200:
        return f"must be at most 200 characters (got {len(name)})"
    if not _SEGMENT.match(name):
        return (f"{name[:60]!r} is not a safe name: use letters, digits and _ . , : = @ + - "
                "(no '/', spaces, or a leading '.' or '-')")
    if name in RESERVED_NAMES:
        return f"{name!r} is a reserved folder name ({', '.join(sorted(RESERVED_NAMES))})"
    return None


def _below_home(name: str) -> property:
    """The path ``home / name`` of a workspace, as a read-only attribute."""
    return property(lambda self: self.home / name, doc=f"home / {name!r}")


@dataclass(frozen=True)
class Workspace:
    """The folder ``home`` and what lives in it."""

    home: Path

    @classmethod
    def at(cls, home) -> "Workspace":
        return cls(Path(home).expanduser().resolve())

    @classmethod
    def from_environment(cls) -> "Workspace":
        home = os.environ.get("HARNESS_HOME")
        return cls.at(home) if home else cls.at(PROJECT_ROOT / ".harness")

    builds = _below_home("builds")
    runs = _below_home("runs")
    sweeps = _below_home("sweeps")
    locks = _below_home("locks")
    database = _below_home("harness.sqlite3")

    def roots(self) -> list[Path]:
        """The workspace and where its own folders really are: ``runs/`` or ``builds/`` may be symlinks to
        another disk, and what lies below them is still the workspace's."""
        return [self.home] + [p.resolve() for p in (self.runs, self.builds, self.sweeps) if p.is_symlink()]

    def contains(self, path) -> bool:
        """Whether ``path`` (symlinks resolved) lies strictly inside the workspace."""
        resolved = Path(path).resolve()
        return any(root in resolved.parents for root in self.roots())

    def remove_tree(self, path) -> None:
        """Delete a file or folder inside the workspace; anything else is refused with a UserError.

        This is the harness' only deleting function. A symlink is removed, never followed.
        """
        path = Path(path)
        parent = path.parent.resolve()
        inside = any(parent == root or root in parent.parents for root in self.roots())
        if not inside or path.name in ("", ".", ".."):
            raise UserError(f"refusing to delete {path}: it is not inside the workspace {self.home}")
        target = parent / path.name
        if target.is_symlink() or target.is_file():
            target.unlink(missing_ok=True)
        elif target.exists():
            # a file that vanishes meanwhile (a program still cleaning its own temporary files) is gone anyway
            shutil.rmtree(target, onerror=_ignore_vanished)

    def fresh_folder(self, path) -> Path:
        """An empty folder at ``path`` inside the workspace (whatever was there is removed)."""
        path = Path(path)
        self.remove_tree(path)
        path.mkdir(parents=True)
        return path

    def lock(self, name: str, timeout: float = -1):
        """A cross-process lock ``locks/<name>.lock`` (``timeout`` s; -1 waits for ever, 0 tries once)."""

        self.locks.mkdir(parents=True, exist_ok=True)
        safe = re.sub(r"[^A-Za-z0-9_.=@+-]", "_", name)[:200]
        return FileLock(str(self.locks / f"{safe}.lock"), timeout=timeout)

    def use_lock(self, target: str, build_key: str) -> "UseLock":
        """The lock a process holds (shared) while it uses a build's binary and run folders, and ``harness gc``
        takes (exclusive, without waiting) before it removes any of them."""
        safe = re.sub(r"[^A-Za-z0-9_.=@+-]", "_", f"use-build-{target}-{build_key}")[:200]
        return UseLock(self.locks / f"{safe}.lock")


class UseLock:
    """A reader/writer lock between processes (``fcntl.flock`` on ``locks/<name>.lock``): any number of
    holders in shared mode - the processes using a build - or one in exclusive mode - ``harness gc`` about to
    remove that build's folders. The kernel releases it when its holder dies (a killed run holds nothing)."""

    def __init__(self, path: Path):
        self.path, self._fd = path, None

    def acquire(self, exclusive: bool = False, blocking: bool = True) -> bool:
        """Take the lock; False when ``blocking`` is off and another process holds it in a conflicting mode."""

        if self._fd is not None:
            return True
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        mode = (fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH) | (0 if blocking else fcntl.LOCK_NB)
        try:
            fcntl.flock(fd, mode)
        except BlockingIOError:
            os.close(fd)
            return False
        self._fd = fd
        return True

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)  # closing the descriptor drops the flock
            self._fd = None


def _ignore_vanished(function, path, exc_info) -> None:
    """``shutil.rmtree``'s error handler (Python 3.11's ``onerror`` form): only a vanished file is ignored."""
    if not issubclass(exc_info[0], FileNotFoundError):
        raise exc_info[1]


_active: Workspace | None = None


def workspace() -> Workspace:
    """The active workspace (set by the CLI), else the one ``HARNESS_HOME`` names, else ``.harness/``."""
    return _active or Workspace.from_environment()


@contextlib.contextmanager
def use_workspace(ws: Workspace):
    """Make ``ws`` the active workspace for the duration of the block."""
    global _active
    previous, _active = _active, ws
    try:
        yield ws
    finally:
        _active = previous
